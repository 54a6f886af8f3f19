// Which configuration keys the parsers accept, as they ask for them: every strict reader (the
// daemon's configuration, the bodies) notes each key it looks up or allows. Nothing is kept
// unless a recording is active on the calling thread, so parsing costs one thread-local test
// per key. The documentation test records a parse of a configuration that has every section and
// compares the keys with docs/configuration.md.
#pragma once

#include <set>
#include <string>

namespace ips {

/// While alive, the keys noted on this thread are added to `out` as full paths
/// ("cameras[0].controls.gain", "markers.ids.7.name"). Recordings do not nest.
class AcceptedKeysRecording {
 public:
  explicit AcceptedKeysRecording(std::set<std::string>& out);
  ~AcceptedKeysRecording();
  AcceptedKeysRecording(const AcceptedKeysRecording&) = delete;
  AcceptedKeysRecording& operator=(const AcceptedKeysRecording&) = delete;
};

/// A parser accepts the key `path` (a no-op without a recording on this thread).
void note_accepted_key(const std::string& path);

}  // namespace ips
