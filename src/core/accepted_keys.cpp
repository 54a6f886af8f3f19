#include "ips/core/accepted_keys.h"

namespace ips {

namespace {
thread_local std::set<std::string>* recording = nullptr;
}  // namespace

AcceptedKeysRecording::AcceptedKeysRecording(std::set<std::string>& out) { recording = &out; }

AcceptedKeysRecording::~AcceptedKeysRecording() { recording = nullptr; }

void note_accepted_key(const std::string& path) {
  if (recording) recording->insert(path);
}

}  // namespace ips
