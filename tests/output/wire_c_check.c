/* Compiled as strict C99 by tests/output/extra.cmake: proves include/ips/output/wire.h is plain C
 * that robot firmware can include, warning-free. */
#include "ips/output/wire.h"

int ips_wire_c_check(const uint8_t* buf, size_t len);
int ips_wire_c_check(const uint8_t* buf, size_t len) {
  struct ips_wire_header h;
  struct ips_wire_marker m;
  int status = ips_wire_read_header(buf, len, &h);
  if (status == IPS_WIRE_OK && h.marker_count > 0) ips_wire_read_marker(buf, &h, 0, &m);
  return status;
}

int ips_wire_c_check_body(const uint8_t* buf, size_t len, char* name_out);
int ips_wire_c_check_body(const uint8_t* buf, size_t len, char* name_out) {
  struct ips_wire_header h;
  struct ips_wire_body b;
  int status = ips_wire_read_header(buf, len, &h);
  if (status == IPS_WIRE_OK && h.body_count > 0) {
    ips_wire_read_body(buf, &h, 0, &b);
    memcpy(name_out, b.name, sizeof b.name);
  }
  return status;
}
