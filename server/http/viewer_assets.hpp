#pragma once
/// The web viewer's files (server/http/viewer/), compiled into strata-server: CMake turns each into
/// bytes of a generated source (server/http/viewer/embed_assets.cmake), so the binary serves the
/// page from any directory, with nothing to install beside it and nothing fetched from a CDN.
#include <span>
#include <string_view>

namespace strata::server {

struct ViewerAsset {
  std::string_view path;          ///< Where it is served: "/viewer.js"; index.html at "/".
  std::string_view content_type;  ///< "text/javascript; charset=utf-8", ...
  std::string_view body;
};

/// Every file of the page.
std::span<const ViewerAsset> ViewerAssets();

}  // namespace strata::server
