// Request routing: a pure function of method and path so that it is tested (and fuzzed by
// the malformed-request test) apart from the server.
#include <string_view>

#include "ips/web/web.h"

namespace ips {

namespace {
// Names in paths (asset files, camera names): a conservative character set; anything else is
// a 400, never a file system path (assets are embedded, nothing is read from disk).
bool valid_name(std::string_view s) {
  if (s.empty() || s.size() > 64 || s.front() == '.') return false;
  for (const char c : s) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
    if (!ok) return false;
  }
  return s.find("..") == std::string_view::npos;
}

bool ends_with(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() && s.substr(s.size() - suffix.size()) == suffix;
}
}  // namespace

Route route_request(const std::string& method, const std::string& path) {
  Route r;
  if (path.empty() || path.front() != '/' || path.size() > 256) {
    r.kind = Route::Kind::kBadRequest;
    return r;
  }
  for (const char c : path) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) {
      r.kind = Route::Kind::kBadRequest;
      return r;
    }
  }
  // Read-only: no POST/PUT/DELETE. HEAD (monitoring tools) is routed like GET; the server
  // then sends the same status and headers without the body.
  if (method != "GET" && method != "HEAD") {
    r.kind = Route::Kind::kBadMethod;
    return r;
  }
  r.head = method == "HEAD";
  const std::string_view p(path);
  if (p == "/" || p == "/index.html") {
    r.kind = Route::Kind::kPage;
  } else if (p == "/status.json") {
    r.kind = Route::Kind::kStatus;
  } else if (p == "/layout.json") {
    r.kind = Route::Kind::kLayout;
  } else if (p == "/events") {
    r.kind = Route::Kind::kEvents;
  } else if (p.starts_with("/assets/")) {
    const std::string_view name = p.substr(8);
    r.kind = valid_name(name) ? Route::Kind::kAsset : Route::Kind::kNotFound;
    r.name = r.kind == Route::Kind::kAsset ? std::string(name) : "";
  } else if (p.starts_with("/camera/")) {
    std::string_view rest = p.substr(8);
    const bool jpg = ends_with(rest, ".jpg"), json = ends_with(rest, ".json");
    if (jpg || json) {
      rest.remove_suffix(jpg ? 4 : 5);
      if (valid_name(rest)) {
        r.kind = jpg ? Route::Kind::kCameraJpeg : Route::Kind::kCameraJson;
        r.name = std::string(rest);
      }
    }
  }
  return r;
}

}  // namespace ips
