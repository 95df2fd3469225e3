// Whole-file writes that never leave a half-written file behind.
//
// The contents go to a sibling "<path>.partial" (the same folder, so the same
// file system) and are renamed over `path` only once they are all on disk: a
// reader sees the old file or the whole new one, and a failed write leaves
// no output.  Used for every file the project writes except PNGs, which
// libpng writes itself (render/png_writer.cpp follows the same rule).
#pragma once

#include <filesystem>
#include <string_view>

namespace overlap::physics {

// Throws std::runtime_error naming `path` when the write or the rename fails.
void writeFileAtomically(const std::filesystem::path& path, std::string_view contents);

}  // namespace overlap::physics
