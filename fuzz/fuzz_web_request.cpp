// The web view's request handling that is ours rather than CivetWeb's (CivetWeb parses the
// HTTP; src/web/server.cpp then routes on method and path): route_request and the embedded
// asset lookup. Input: "METHOD PATH" (the first space splits them; CivetWeb hands the path
// already without its query string). Beyond "no fault": whatever is routed to an asset or a
// camera carries a name that cannot leave its namespace (no '/', no "..", printable), only GET
// and HEAD are ever served, and exactly HEAD is answered without a body.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "fuzz_util.h"
#include "ips/web/web.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(ips::fuzz::as_text(data, size));
  const std::size_t space = text.find(' ');
  const std::string method = space == std::string::npos ? "GET" : text.substr(0, space);
  const std::string path = space == std::string::npos ? text : text.substr(space + 1);
  const ips::Route r = ips::route_request(method, path);
  using Kind = ips::Route::Kind;
  const bool served = r.kind != Kind::kBadRequest && r.kind != Kind::kBadMethod && r.kind != Kind::kNotFound;
  if (served && method != "GET" && method != "HEAD") std::abort();
  if (served && r.head != (method == "HEAD")) std::abort();
  if (r.kind == Kind::kAsset || r.kind == Kind::kCameraJpeg || r.kind == Kind::kCameraJson) {
    if (r.name.empty() || r.name.find('/') != std::string::npos || r.name.find("..") != std::string::npos) std::abort();
    for (const char c : r.name)
      if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f) std::abort();
  }
  if (r.kind == Kind::kAsset) {
    if (const ips::Asset* a = ips::find_asset(r.name)) {
      if (a->name != r.name || (a->size > 0 && !a->data)) std::abort();
    }
  }
  return 0;
}
