#include "ips/capture/camera_settings.h"

namespace ips {

const char* to_string(SourceKind kind) {
  switch (kind) {
    case SourceKind::kV4l2: return "v4l2";
    case SourceKind::kFile: return "file";
    case SourceKind::kSynthetic: return "synthetic";
  }
  return "?";
}

}  // namespace ips
