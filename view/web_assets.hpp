#pragma once
// The page's files (view/web/), embedded into the program at build time by CMake
// (view/embed_web.cmake writes web_assets.cpp), so the program serves them without reading any
// file: no path from a request ever reaches the file system.

#include <span>
#include <string_view>

namespace esfleet::view {

struct WebAsset {
  std::string_view path;  ///< URL path, "/" for the page
  std::string_view content_type;
  std::string_view body;
};

/// Every embedded file.
std::span<const WebAsset> web_assets();
/// The asset served at exactly `path`, or nullptr.
const WebAsset* find_web_asset(std::string_view path);

}  // namespace esfleet::view
