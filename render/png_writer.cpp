// encodePng (declared in renderer.h), through libpng's simplified API: it
// reports errors by return value instead of longjmp, and writes no tIME chunk.
#include <png.h>

#include <string>

#include "render/renderer.h"

namespace overlap::render {

std::string encodePng(const Image& image) {
  const std::string where = "cannot encode the PNG: ";
  const auto expected_bytes = 4 * static_cast<std::size_t>(image.width > 0 ? image.width : 0) *
                              static_cast<std::size_t>(image.height > 0 ? image.height : 0);
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != expected_bytes) {
    throw RenderError(where + "the image is " + std::to_string(image.width) + "x" +
                      std::to_string(image.height) + " with " + std::to_string(image.rgba.size()) +
                      " bytes of RGBA");
  }
  png_image description{};
  description.version = PNG_IMAGE_VERSION;
  description.width = static_cast<png_uint_32>(image.width);
  description.height = static_cast<png_uint_32>(image.height);
  description.format = PNG_FORMAT_RGBA;
  // The first call sizes the buffer, the second fills it.
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&description, nullptr, &size, 0, image.rgba.data(), 0, nullptr)) {
    throw RenderError(where + description.message);
  }
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&description, bytes.data(), &size, 0, image.rgba.data(), 0,
                                 nullptr)) {
    throw RenderError(where + description.message);
  }
  bytes.resize(size);
  return bytes;
}

}  // namespace overlap::render
