#include "ips/capture/libjpeg_errors.h"

namespace ips {
namespace {

[[noreturn]] void on_error(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<LibjpegErrors*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

void on_message_fatal_warnings(j_common_ptr cinfo, int level) {
  if (level < 0) on_error(cinfo);
}

}  // namespace

jpeg_error_mgr* install_libjpeg_errors(LibjpegErrors& errors, bool warnings_are_errors) {
  jpeg_error_mgr* mgr = jpeg_std_error(&errors.pub);
  errors.pub.error_exit = on_error;
  if (warnings_are_errors) errors.pub.emit_message = on_message_fatal_warnings;
  errors.message[0] = '\0';
  return mgr;
}

}  // namespace ips
