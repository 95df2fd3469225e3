# Run at build time (cmake -P): writes OUT_FILE with the git commit and build
# type, rewriting it only when they change so nothing rebuilds needlessly.
execute_process(COMMAND git -C "${SOURCE_DIR}" rev-parse --short=12 HEAD
                OUTPUT_VARIABLE commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET
                RESULT_VARIABLE git_failed)
if(git_failed OR commit STREQUAL "")
  set(commit "unknown")
else()
  execute_process(COMMAND git -C "${SOURCE_DIR}" status --porcelain --untracked-files=no
                  OUTPUT_VARIABLE dirty OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(NOT dirty STREQUAL "")
    string(APPEND commit "-dirty")
  endif()
endif()
set(content "#pragma once\n#define OVERLAP_GIT_COMMIT \"${commit}\"\n#define OVERLAP_BUILD_TYPE \"${BUILD_TYPE}\"\n")
if(EXISTS "${OUT_FILE}")
  file(READ "${OUT_FILE}" old)
endif()
if(NOT old STREQUAL content)
  file(WRITE "${OUT_FILE}" "${content}")
endif()
