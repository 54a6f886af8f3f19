#pragma once
// libjpeg's error handling, set up once for every libjpeg user here (the region decoder, the
// simulator's encoder with restart markers). libjpeg reports a fatal error through a callback
// that must not return; ours formats the message and jumps back to the caller's setjmp, which
// then cleans up and reports the message as an error of its own.
#include <csetjmp>
#include <cstddef>
#include <cstdio>

// jpeglib.h needs FILE and size_t declared first.
#include <jpeglib.h>

namespace ips {

struct LibjpegErrors {
  jpeg_error_mgr pub;  // first: libjpeg sees only this part
  std::jmp_buf jump;   // setjmp here before every libjpeg call that can fail
  char message[JMSG_LENGTH_MAX];
};

// Fills `errors` and returns what goes into a libjpeg struct's `err`. With
// `warnings_are_errors`, a warning (a truncated or damaged stream) is fatal too, so that a
// half-decoded frame never reaches the detector; trace messages are ignored either way.
jpeg_error_mgr* install_libjpeg_errors(LibjpegErrors& errors, bool warnings_are_errors);

}  // namespace ips
