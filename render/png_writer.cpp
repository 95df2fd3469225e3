// writePng (declared in renderer.h), through libpng's simplified API: it
// reports errors by return value instead of longjmp, and writes no tIME chunk.
#include <png.h>

#include <string>
#include <system_error>

#include "render/renderer.h"

namespace overlap::render {

void writePng(const Image& image, const std::filesystem::path& path) {
  const std::string where = "cannot write the PNG " + path.string() + ": ";
  const auto expected_bytes = 4 * static_cast<std::size_t>(image.width > 0 ? image.width : 0) *
                              static_cast<std::size_t>(image.height > 0 ? image.height : 0);
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != expected_bytes) {
    throw RenderError(where + "the image is " + std::to_string(image.width) + "x" +
                      std::to_string(image.height) + " with " + std::to_string(image.rgba.size()) +
                      " bytes of RGBA");
  }
  // A sibling file, so the rename stays on one file system and is atomic.
  std::filesystem::path partial = path;
  partial += ".partial";

  png_image description{};
  description.version = PNG_IMAGE_VERSION;
  description.width = static_cast<png_uint_32>(image.width);
  description.height = static_cast<png_uint_32>(image.height);
  description.format = PNG_FORMAT_RGBA;
  if (!png_image_write_to_file(&description, partial.c_str(), 0, image.rgba.data(), 0, nullptr)) {
    // libpng has already removed the file it failed to finish.
    throw RenderError(where + description.message);
  }
  std::error_code error;
  std::filesystem::rename(partial, path, error);
  if (error) {
    std::filesystem::remove(partial);
    throw RenderError(where + error.message());
  }
}

}  // namespace overlap::render
