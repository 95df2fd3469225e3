// Mesa's OSMesa keeps a small framebuffer record (about 200 bytes) for every
// context made current and never frees it, even in OSMesaDestroyContext.  The
// leak is Mesa's and bounded by the number of renderers, so LeakSanitizer is
// told to ignore it; any other leak in a sanitizer build still fails.
// LeakSanitizer calls this hook if it is linked in; other builds ignore it.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:libOSMesa.so\n";
}
