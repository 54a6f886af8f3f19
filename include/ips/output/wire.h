/* The ipsd position stream, binary form: the byte layout of one UDP datagram.
 *
 * Plain C99, no dependencies beyond <stdint.h>/<string.h>, so robot firmware can include it
 * as is. Every multi-byte field is LITTLE-ENDIAN, whatever the host; the read helpers below
 * assemble values byte by byte, so they are correct on big-endian hosts and need no alignment.
 * Never memcpy a host struct onto the wire.
 *
 * A datagram = one header (IPS_WIRE_HEADER_SIZE bytes) + marker_count records of
 * record_size bytes each; in version 2, then a body section (below). A receiver must use
 * record_size (and body_record_size) from the datagram (not a constant) to step through the
 * records: later protocol minor revisions may append fields to a record, and an old receiver
 * then skips them.
 *
 * Versions: ipsd sends version 1 when its configuration has no `bodies:`, version 2 when it
 * has (docs/bodies.md). A version-1-only receiver refuses version 2 (IPS_WIRE_BAD_VERSION);
 * these helpers read both. Version 2 = version 1 + the body section; the header and the
 * marker records are the same.
 *
 * Header, 48 bytes:
 *   off size type  field
 *     0    4 u8[4] magic: the ASCII bytes 'I' 'P' 'S' 'D'
 *     4    2 u16   version: protocol version, 1 or 2
 *     6    2 u16   flags: bit 0 = records carry velocity (IPS_WIRE_FLAG_VELOCITY); bit 1 =
 *                  records carry their sources (IPS_WIRE_FLAG_SOURCES); other bits 0, and a
 *                  receiver ignores bits it does not know
 *     8    4 u32   sequence: datagram counter of this output, +1 per datagram (wraps at 2^32);
 *                  a gap means a lost datagram
 *    12    2 u16   marker_count: records in this datagram
 *    14    2 u16   record_size: bytes per record (36; 48 with velocity; 52 with sources)
 *    16    1 u8    part: index of this datagram within its update, 0-based
 *    17    1 u8    parts: datagrams the update was split into (>= 1)
 *    18    2 u16   reserved, 0
 *    20    4 u32   update: fused-update counter (the same for every part and every output)
 *    24    8 i64   capture_realtime_ns: capture time of the camera frame that produced the update
 *                  (with a fixed output rate: the time the states were predicted to), CLOCK_REALTIME
 *    32    8 i64   capture_monotonic_ns: the same instant on the daemon host's CLOCK_MONOTONIC
 *    40    8 i64   publish_realtime_ns: when the daemon encoded the datagram, CLOCK_REALTIME
 *
 * Marker record, 36 bytes (48 with velocity):
 *   off size type  field
 *     0    4 u32   id: ArUco marker id
 *     4    4 u32   camera_mask: bit i set = camera i of the daemon's configuration contributed
 *     8    4 f32   x, metres, world frame
 *    12    4 f32   y, metres
 *    16    4 f32   z, metres
 *    20    4 f32   yaw, radians in (-pi, pi], heading of the marker's x-axis in the world x-y plane
 *    24    4 f32   quality: sum of the contributing observations' marker areas in the image, px^2
 *                  (larger = closer / better resolved; 0 = none)
 *    28    4 f32   spread, metres: largest distance of a contributing camera's estimate from the
 *                  fused position (0 for a single camera); a disagreement figure
 *    32    4 i32   dt_us: this marker's time minus the header's capture time, microseconds (<= 0;
 *                  0 from ipsd's asynchronous fusion: every record is the state at the header's
 *                  time). Per marker id, header time + dt_us never decreases along the stream.
 *   with IPS_WIRE_FLAG_VELOCITY:
 *    36    4 f32   vx, m/s (constant-velocity Kalman filter)
 *    40    4 f32   vy, m/s
 *    44    4 f32   vz, m/s
 *   with IPS_WIRE_FLAG_SOURCES (ipsd sets it when its configuration has `ranging:` or a camera
 *   `on_robot:`; the record then always holds the velocity fields, 0 without
 *   IPS_WIRE_FLAG_VELOCITY):
 *    48    2 u16   sources: what the position came from, a bit per kind: bit 0 =
 *                  IPS_WIRE_SOURCE_CAMERA (the cameras of camera_mask), bit 1 =
 *                  IPS_WIRE_SOURCE_RANGES (UWB / ultrasound ranges, docs/ranging.md), bit 2 =
 *                  IPS_WIRE_SOURCE_INSIDE_OUT (the robot's own up-facing camera reading the
 *                  ceiling's markers, docs/inside-out.md); a record without the cameras has
 *                  camera_mask 0 and quality 0. Later sources take later bits.
 *    50    2 u16   marker_flags: bit 0 = IPS_WIRE_MARKER_HAS_YAW (yaw was measured at this
 *                  record's time; 0 = the last measured heading held, e.g. from ranges alone)
 *   Without IPS_WIRE_FLAG_SOURCES every record is from the cameras with a measured yaw
 *   (ips_wire_read_marker fills sources and marker_flags so).
 *
 * Minor revisions: a sender adds fields only at the end of a record, announced by a new flag
 * bit, and keeps every earlier field where it was; a receiver that steps by record_size and
 * ignores flag bits it does not know reads every revision.
 *
 * Version 2 only: the body section, right after the marker records (at byte
 * B = 48 + marker_count * record_size). A marker that belongs to a body is published inside
 * its body only, never also as a marker record.
 *   off size type  field
 *   B+0    2 u16   body_count: body records that follow
 *   B+2    2 u16   body_record_size: bytes per body record (116; 100 from the first senders)
 * The datagram is exactly B + 4 + body_count * body_record_size bytes.
 *
 * Body record, 116 bytes (the first ipsd with bodies sent 100: fields up to byte 100, no
 * velocity; a receiver accepts body_record_size >= 100 and reads velocity only from records
 * of at least 116 bytes):
 *   off size type     field
 *     0   32 char[32] name: the body's name (config bodies[].name), UTF-8, NUL-padded; at most
 *                     31 bytes, so it is always NUL-terminated
 *    32    4 u32      camera_mask: bit i set = camera i contributed
 *    36    4 f32      x, metres, world frame: the body origin
 *    40    4 f32      y, metres
 *    44    4 f32      z, metres (0 for a ground body: its origin is on the floor)
 *    48    4 f32      yaw, radians in (-pi, pi]: heading of the body x axis
 *    52    4 f32      qw  \
 *    56    4 f32      qx   | orientation, body -> world, unit quaternion (a ground body:
 *    60    4 f32      qy   | the yaw about world z)
 *    64    4 f32      qz  /
 *    68    4 f32      quality: sum of the contributing marker areas in the images, px^2
 *    72    4 f32      spread, metres: largest distance of a contributing view's body position
 *                     from the fused one
 *    76    4 i32      dt_us: this body's time minus the header's capture time, microseconds
 *                     (<= 0; 0 per camera frame, the age of the body's newest pose with a fixed
 *                     output rate). Per body name, header time + dt_us never decreases.
 *    80    2 u16      body_flags: bit 0 = IPS_WIRE_BODY_HAS_YAW (yaw and quaternion are
 *                     measured; 0 = position only, e.g. a cube side seen with no face known);
 *                     bit 1 = IPS_WIRE_BODY_HAS_VELOCITY (vx, vy, vz measured); bit 2 =
 *                     IPS_WIRE_BODY_HAS_YAW_RATE (yaw_rate measured); other bits 0
 *    82    2 u16      id_count: distinct marker ids that contributed
 *    84   16 u32[4]   ids: the first min(id_count, 4) of them, ascending; the rest 0
 *   100    4 f32      vx, m/s, world frame: the body's own published positions over the
 *   104    4 f32      vy, m/s               daemon's fusion.velocity_span (a mean over that
 *   108    4 f32      vz, m/s               span, not a filter); 0 without HAS_VELOCITY
 *   112    4 f32      yaw_rate, rad/s about world z, over the same span; 0 without HAS_YAW_RATE
 *   with IPS_WIRE_FLAG_SOURCES in the header (ipsd with `ranging:`), the record is 120 bytes:
 *   116    2 u16      sources: IPS_WIRE_SOURCE_* bits as in a marker record; a body placed by
 *                     ranges alone (a ranging tag on it, docs/ranging.md) has camera_mask 0,
 *                     quality 0 and IPS_WIRE_BODY_HAS_YAW clear (its yaw and quaternion are the
 *                     last measured ones, held)
 *   118    2 u16      reserved, 0
 *   A record shorter than 120 bytes, or without the header flag, is from the cameras (the
 *   first ipsd with ranges sent 116-byte body records with the flag set).
 */
#ifndef IPS_WIRE_H
#define IPS_WIRE_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#ifdef __cplusplus
/* C casts are this header's idiom (it is C for firmware); C++ projects warn on them (clang). */
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wold-style-cast"
extern "C" {
#endif

#define IPS_WIRE_MAGIC_0 'I'
#define IPS_WIRE_MAGIC_1 'P'
#define IPS_WIRE_MAGIC_2 'S'
#define IPS_WIRE_MAGIC_3 'D'
#define IPS_WIRE_VERSION 1u   /* without bodies */
#define IPS_WIRE_VERSION_2 2u /* with the body section */
#define IPS_WIRE_FLAG_VELOCITY 0x0001u
#define IPS_WIRE_FLAG_SOURCES 0x0002u
#define IPS_WIRE_HEADER_SIZE 48u
#define IPS_WIRE_RECORD_SIZE 36u          /* without velocity */
#define IPS_WIRE_RECORD_SIZE_VELOCITY 48u /* with velocity */
#define IPS_WIRE_RECORD_SIZE_SOURCES 52u  /* with sources (velocity fields always present) */
/* Marker record: sources bits and marker_flags bits. */
#define IPS_WIRE_SOURCE_CAMERA 0x0001u
#define IPS_WIRE_SOURCE_RANGES 0x0002u
#define IPS_WIRE_SOURCE_INSIDE_OUT 0x0004u
#define IPS_WIRE_MARKER_HAS_YAW 0x0001u
/* Every datagram (binary or JSON) is at most this many bytes, below common path MTUs. */
#define IPS_WIRE_MAX_DATAGRAM 1199u

/* Header field offsets. */
#define IPS_WIRE_OFF_MAGIC 0u
#define IPS_WIRE_OFF_VERSION 4u
#define IPS_WIRE_OFF_FLAGS 6u
#define IPS_WIRE_OFF_SEQUENCE 8u
#define IPS_WIRE_OFF_MARKER_COUNT 12u
#define IPS_WIRE_OFF_RECORD_SIZE 14u
#define IPS_WIRE_OFF_PART 16u
#define IPS_WIRE_OFF_PARTS 17u
#define IPS_WIRE_OFF_RESERVED 18u
#define IPS_WIRE_OFF_UPDATE 20u
#define IPS_WIRE_OFF_CAPTURE_REALTIME 24u
#define IPS_WIRE_OFF_CAPTURE_MONOTONIC 32u
#define IPS_WIRE_OFF_PUBLISH_REALTIME 40u

/* Record field offsets. */
#define IPS_WIRE_REC_ID 0u
#define IPS_WIRE_REC_CAMERA_MASK 4u
#define IPS_WIRE_REC_X 8u
#define IPS_WIRE_REC_Y 12u
#define IPS_WIRE_REC_Z 16u
#define IPS_WIRE_REC_YAW 20u
#define IPS_WIRE_REC_QUALITY 24u
#define IPS_WIRE_REC_SPREAD 28u
#define IPS_WIRE_REC_DT_US 32u
#define IPS_WIRE_REC_VX 36u
#define IPS_WIRE_REC_VY 40u
#define IPS_WIRE_REC_VZ 44u
#define IPS_WIRE_REC_SOURCES 48u
#define IPS_WIRE_REC_MARKER_FLAGS 50u

/* Version 2: the body section and its records. */
#define IPS_WIRE_BODY_SECTION_SIZE 4u
#define IPS_WIRE_BODY_RECORD_SIZE 116u /* what ipsd sends */
#define IPS_WIRE_BODY_RECORD_MIN 100u  /* the smallest a receiver accepts (no velocity) */
#define IPS_WIRE_BODY_NAME_SIZE 32u
#define IPS_WIRE_BODY_MAX_IDS 4u
#define IPS_WIRE_BODY_HAS_YAW 0x0001u
#define IPS_WIRE_BODY_HAS_VELOCITY 0x0002u
#define IPS_WIRE_BODY_HAS_YAW_RATE 0x0004u
#define IPS_WIRE_BODY_NAME 0u
#define IPS_WIRE_BODY_CAMERA_MASK 32u
#define IPS_WIRE_BODY_X 36u
#define IPS_WIRE_BODY_Y 40u
#define IPS_WIRE_BODY_Z 44u
#define IPS_WIRE_BODY_YAW 48u
#define IPS_WIRE_BODY_QW 52u
#define IPS_WIRE_BODY_QX 56u
#define IPS_WIRE_BODY_QY 60u
#define IPS_WIRE_BODY_QZ 64u
#define IPS_WIRE_BODY_QUALITY 68u
#define IPS_WIRE_BODY_SPREAD 72u
#define IPS_WIRE_BODY_DT_US 76u
#define IPS_WIRE_BODY_FLAGS 80u
#define IPS_WIRE_BODY_ID_COUNT 82u
#define IPS_WIRE_BODY_IDS 84u
#define IPS_WIRE_BODY_VX 100u
#define IPS_WIRE_BODY_VY 104u
#define IPS_WIRE_BODY_VZ 108u
#define IPS_WIRE_BODY_YAW_RATE 112u
#define IPS_WIRE_BODY_SOURCES 116u
#define IPS_WIRE_BODY_RECORD_SIZE_SOURCES 120u /* what ipsd sends with IPS_WIRE_FLAG_SOURCES */

/* ---- little-endian readers (byte-wise: any host byte order, any alignment) ---- */
static inline uint16_t ips_wire_get_u16(const uint8_t* p) {
  return (uint16_t)((uint16_t)p[0] | (uint16_t)((uint16_t)p[1] << 8));
}
static inline uint32_t ips_wire_get_u32(const uint8_t* p) {
  return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static inline uint64_t ips_wire_get_u64(const uint8_t* p) {
  return (uint64_t)ips_wire_get_u32(p) | ((uint64_t)ips_wire_get_u32(p + 4) << 32);
}
static inline int32_t ips_wire_get_i32(const uint8_t* p) {
  uint32_t u = ips_wire_get_u32(p);
  int32_t v;
  memcpy(&v, &u, sizeof v); /* two's complement reinterpretation, no UB */
  return v;
}
static inline int64_t ips_wire_get_i64(const uint8_t* p) {
  uint64_t u = ips_wire_get_u64(p);
  int64_t v;
  memcpy(&v, &u, sizeof v);
  return v;
}
/* IEEE-754 binary32 (the host's float must be IEEE-754, true on every current MCU/CPU). */
static inline float ips_wire_get_f32(const uint8_t* p) {
  uint32_t u = ips_wire_get_u32(p);
  float f;
  memcpy(&f, &u, sizeof f);
  return f;
}

/* ---- little-endian writers ---- */
static inline void ips_wire_put_u16(uint8_t* p, uint16_t v) {
  p[0] = (uint8_t)(v & 0xffu);
  p[1] = (uint8_t)(v >> 8);
}
static inline void ips_wire_put_u32(uint8_t* p, uint32_t v) {
  p[0] = (uint8_t)(v & 0xffu);
  p[1] = (uint8_t)((v >> 8) & 0xffu);
  p[2] = (uint8_t)((v >> 16) & 0xffu);
  p[3] = (uint8_t)(v >> 24);
}
static inline void ips_wire_put_u64(uint8_t* p, uint64_t v) {
  ips_wire_put_u32(p, (uint32_t)(v & 0xffffffffu));
  ips_wire_put_u32(p + 4, (uint32_t)(v >> 32));
}
static inline void ips_wire_put_i32(uint8_t* p, int32_t v) {
  uint32_t u;
  memcpy(&u, &v, sizeof u);
  ips_wire_put_u32(p, u);
}
static inline void ips_wire_put_i64(uint8_t* p, int64_t v) {
  uint64_t u;
  memcpy(&u, &v, sizeof u);
  ips_wire_put_u64(p, u);
}
static inline void ips_wire_put_f32(uint8_t* p, float f) {
  uint32_t u;
  memcpy(&u, &f, sizeof u);
  ips_wire_put_u32(p, u);
}

/* ---- decoded forms, for firmware that wants structs ---- */
struct ips_wire_header {
  uint16_t version;
  uint16_t flags;
  uint32_t sequence;
  uint16_t marker_count;
  uint16_t record_size;
  uint8_t part;
  uint8_t parts;
  uint32_t update;
  int64_t capture_realtime_ns;
  int64_t capture_monotonic_ns;
  int64_t publish_realtime_ns;
  /* version 2 (both 0 in version 1) */
  uint16_t body_count;
  uint16_t body_record_size;
};

struct ips_wire_marker {
  uint32_t id;
  uint32_t camera_mask;
  float x, y, z, yaw;
  float quality;
  float spread;
  int32_t dt_us;
  float vx, vy, vz;      /* 0 unless the header has IPS_WIRE_FLAG_VELOCITY */
  uint16_t sources;      /* IPS_WIRE_SOURCE_* bits (CAMERA without IPS_WIRE_FLAG_SOURCES) */
  uint16_t marker_flags; /* IPS_WIRE_MARKER_HAS_YAW (set without IPS_WIRE_FLAG_SOURCES) */
};

enum ips_wire_status {
  IPS_WIRE_OK = 0,
  IPS_WIRE_TOO_SHORT = -1,           /* shorter than a header */
  IPS_WIRE_BAD_MAGIC = -2,           /* not an ipsd binary datagram */
  IPS_WIRE_BAD_VERSION = -3,         /* a protocol version this header does not describe */
  IPS_WIRE_BAD_RECORD_SIZE = -4,     /* record_size smaller than the fields the flags announce */
  IPS_WIRE_BAD_LENGTH = -5,          /* length != header + marker_count * record_size */
  IPS_WIRE_BAD_PARTS = -6,           /* parts == 0 or part >= parts */
  IPS_WIRE_BAD_BODY_RECORD_SIZE = -7 /* version 2: body_record_size smaller than a body record */
};

/* Version 2 body record, decoded. */
struct ips_wire_body {
  char name[IPS_WIRE_BODY_NAME_SIZE]; /* always NUL-terminated after ips_wire_read_body */
  uint32_t camera_mask;
  float x, y, z, yaw;
  float qw, qx, qy, qz;
  float quality;
  float spread;
  int32_t dt_us;
  uint16_t flags; /* IPS_WIRE_BODY_HAS_YAW | _HAS_VELOCITY | _HAS_YAW_RATE */
  uint16_t id_count;
  uint32_t ids[IPS_WIRE_BODY_MAX_IDS];
  float vx, vy, vz; /* 0 unless flags has IPS_WIRE_BODY_HAS_VELOCITY */
  float yaw_rate;   /* 0 unless flags has IPS_WIRE_BODY_HAS_YAW_RATE */
  uint16_t sources; /* IPS_WIRE_SOURCE_* bits (CAMERA in records without them) */
};

/* Validates a whole datagram and decodes its header. Returns IPS_WIRE_OK or a negative
 * ips_wire_status. After IPS_WIRE_OK, records 0..marker_count-1 can be read with
 * ips_wire_read_marker(). */
static inline int ips_wire_read_header(const uint8_t* buf, size_t len, struct ips_wire_header* h) {
  uint16_t min_record;
  if (len < IPS_WIRE_HEADER_SIZE) return IPS_WIRE_TOO_SHORT;
  if (buf[0] != (uint8_t)IPS_WIRE_MAGIC_0 || buf[1] != (uint8_t)IPS_WIRE_MAGIC_1 ||
      buf[2] != (uint8_t)IPS_WIRE_MAGIC_2 || buf[3] != (uint8_t)IPS_WIRE_MAGIC_3)
    return IPS_WIRE_BAD_MAGIC;
  h->version = ips_wire_get_u16(buf + IPS_WIRE_OFF_VERSION);
  h->body_count = 0;
  h->body_record_size = 0;
  if (h->version != IPS_WIRE_VERSION && h->version != IPS_WIRE_VERSION_2) return IPS_WIRE_BAD_VERSION;
  h->flags = ips_wire_get_u16(buf + IPS_WIRE_OFF_FLAGS);
  h->sequence = ips_wire_get_u32(buf + IPS_WIRE_OFF_SEQUENCE);
  h->marker_count = ips_wire_get_u16(buf + IPS_WIRE_OFF_MARKER_COUNT);
  h->record_size = ips_wire_get_u16(buf + IPS_WIRE_OFF_RECORD_SIZE);
  h->part = buf[IPS_WIRE_OFF_PART];
  h->parts = buf[IPS_WIRE_OFF_PARTS];
  h->update = ips_wire_get_u32(buf + IPS_WIRE_OFF_UPDATE);
  h->capture_realtime_ns = ips_wire_get_i64(buf + IPS_WIRE_OFF_CAPTURE_REALTIME);
  h->capture_monotonic_ns = ips_wire_get_i64(buf + IPS_WIRE_OFF_CAPTURE_MONOTONIC);
  h->publish_realtime_ns = ips_wire_get_i64(buf + IPS_WIRE_OFF_PUBLISH_REALTIME);
  min_record = (h->flags & IPS_WIRE_FLAG_SOURCES)    ? IPS_WIRE_RECORD_SIZE_SOURCES
               : (h->flags & IPS_WIRE_FLAG_VELOCITY) ? IPS_WIRE_RECORD_SIZE_VELOCITY
                                                     : IPS_WIRE_RECORD_SIZE;
  if (h->record_size < min_record) return IPS_WIRE_BAD_RECORD_SIZE;
  {
    const uint64_t markers_end = (uint64_t)IPS_WIRE_HEADER_SIZE + (uint64_t)h->marker_count * h->record_size;
    if (h->version == IPS_WIRE_VERSION) {
      if ((uint64_t)len != markers_end) return IPS_WIRE_BAD_LENGTH;
    } else {
      if ((uint64_t)len < markers_end + IPS_WIRE_BODY_SECTION_SIZE) return IPS_WIRE_BAD_LENGTH;
      h->body_count = ips_wire_get_u16(buf + markers_end);
      h->body_record_size = ips_wire_get_u16(buf + markers_end + 2);
      if (h->body_record_size < IPS_WIRE_BODY_RECORD_MIN) return IPS_WIRE_BAD_BODY_RECORD_SIZE;
      if ((uint64_t)len != markers_end + IPS_WIRE_BODY_SECTION_SIZE + (uint64_t)h->body_count * h->body_record_size)
        return IPS_WIRE_BAD_LENGTH;
    }
  }
  if (h->parts == 0 || h->part >= h->parts) return IPS_WIRE_BAD_PARTS;
  return IPS_WIRE_OK;
}

/* Decodes record `index` (< h->marker_count) of a datagram validated by ips_wire_read_header. */
static inline void ips_wire_read_marker(const uint8_t* buf, const struct ips_wire_header* h, uint16_t index,
                                        struct ips_wire_marker* m) {
  const uint8_t* r = buf + IPS_WIRE_HEADER_SIZE + (size_t)index * h->record_size;
  m->id = ips_wire_get_u32(r + IPS_WIRE_REC_ID);
  m->camera_mask = ips_wire_get_u32(r + IPS_WIRE_REC_CAMERA_MASK);
  m->x = ips_wire_get_f32(r + IPS_WIRE_REC_X);
  m->y = ips_wire_get_f32(r + IPS_WIRE_REC_Y);
  m->z = ips_wire_get_f32(r + IPS_WIRE_REC_Z);
  m->yaw = ips_wire_get_f32(r + IPS_WIRE_REC_YAW);
  m->quality = ips_wire_get_f32(r + IPS_WIRE_REC_QUALITY);
  m->spread = ips_wire_get_f32(r + IPS_WIRE_REC_SPREAD);
  m->dt_us = ips_wire_get_i32(r + IPS_WIRE_REC_DT_US);
  if (h->flags & IPS_WIRE_FLAG_VELOCITY) {
    m->vx = ips_wire_get_f32(r + IPS_WIRE_REC_VX);
    m->vy = ips_wire_get_f32(r + IPS_WIRE_REC_VY);
    m->vz = ips_wire_get_f32(r + IPS_WIRE_REC_VZ);
  } else {
    m->vx = m->vy = m->vz = 0.0f;
  }
  if (h->flags & IPS_WIRE_FLAG_SOURCES) {
    m->sources = ips_wire_get_u16(r + IPS_WIRE_REC_SOURCES);
    m->marker_flags = ips_wire_get_u16(r + IPS_WIRE_REC_MARKER_FLAGS);
  } else {
    m->sources = IPS_WIRE_SOURCE_CAMERA;
    m->marker_flags = IPS_WIRE_MARKER_HAS_YAW;
  }
}

/* Decodes body record `index` (< h->body_count) of a version-2 datagram validated by
 * ips_wire_read_header. */
static inline void ips_wire_read_body(const uint8_t* buf, const struct ips_wire_header* h, uint16_t index,
                                      struct ips_wire_body* b) {
  const uint8_t* r = buf + IPS_WIRE_HEADER_SIZE + (size_t)h->marker_count * h->record_size +
                     IPS_WIRE_BODY_SECTION_SIZE + (size_t)index * h->body_record_size;
  unsigned i;
  memcpy(b->name, r + IPS_WIRE_BODY_NAME, IPS_WIRE_BODY_NAME_SIZE);
  b->name[IPS_WIRE_BODY_NAME_SIZE - 1] = '\0';
  b->camera_mask = ips_wire_get_u32(r + IPS_WIRE_BODY_CAMERA_MASK);
  b->x = ips_wire_get_f32(r + IPS_WIRE_BODY_X);
  b->y = ips_wire_get_f32(r + IPS_WIRE_BODY_Y);
  b->z = ips_wire_get_f32(r + IPS_WIRE_BODY_Z);
  b->yaw = ips_wire_get_f32(r + IPS_WIRE_BODY_YAW);
  b->qw = ips_wire_get_f32(r + IPS_WIRE_BODY_QW);
  b->qx = ips_wire_get_f32(r + IPS_WIRE_BODY_QX);
  b->qy = ips_wire_get_f32(r + IPS_WIRE_BODY_QY);
  b->qz = ips_wire_get_f32(r + IPS_WIRE_BODY_QZ);
  b->quality = ips_wire_get_f32(r + IPS_WIRE_BODY_QUALITY);
  b->spread = ips_wire_get_f32(r + IPS_WIRE_BODY_SPREAD);
  b->dt_us = ips_wire_get_i32(r + IPS_WIRE_BODY_DT_US);
  b->flags = ips_wire_get_u16(r + IPS_WIRE_BODY_FLAGS);
  b->id_count = ips_wire_get_u16(r + IPS_WIRE_BODY_ID_COUNT);
  for (i = 0; i < IPS_WIRE_BODY_MAX_IDS; ++i) b->ids[i] = ips_wire_get_u32(r + IPS_WIRE_BODY_IDS + 4u * i);
  b->vx = b->vy = b->vz = b->yaw_rate = 0.0f;
  b->sources = (h->flags & IPS_WIRE_FLAG_SOURCES) && h->body_record_size >= IPS_WIRE_BODY_RECORD_SIZE_SOURCES
                   ? ips_wire_get_u16(r + IPS_WIRE_BODY_SOURCES)
                   : IPS_WIRE_SOURCE_CAMERA;
  if (h->body_record_size < IPS_WIRE_BODY_RECORD_SIZE) {
    /* A 100-byte record (no velocity fields): whatever its flags say, nothing was measured. */
    b->flags = (uint16_t)(b->flags & ~(IPS_WIRE_BODY_HAS_VELOCITY | IPS_WIRE_BODY_HAS_YAW_RATE));
    return;
  }
  if (b->flags & IPS_WIRE_BODY_HAS_VELOCITY) {
    b->vx = ips_wire_get_f32(r + IPS_WIRE_BODY_VX);
    b->vy = ips_wire_get_f32(r + IPS_WIRE_BODY_VY);
    b->vz = ips_wire_get_f32(r + IPS_WIRE_BODY_VZ);
  }
  if (b->flags & IPS_WIRE_BODY_HAS_YAW_RATE) b->yaw_rate = ips_wire_get_f32(r + IPS_WIRE_BODY_YAW_RATE);
}

/* ---- Unicast subscriptions (output `type: subscriptions`) ----
 *
 * A robot (e.g. on Wi-Fi, where multicast is slow and lossy) asks the daemon's subscription
 * port for its own unicast copy of the stream above. Every field little-endian.
 *
 * Request, robot -> daemon: IPS_SUB_REQUEST_HEADER + 4 * id_count bytes, then (only when the
 * daemon has a pre-shared key) IPS_SUB_MAC_SIZE bytes of HMAC-SHA256(key, every byte before it).
 *   off size type   field
 *     0    4 u8[4]  magic: 'I' 'P' 'S' 'Q'
 *     4    1 u8     version: 1
 *     5    1 u8     op: IPS_SUB_OP_SUBSCRIBE (also renews) | IPS_SUB_OP_UNSUBSCRIBE
 *     6    1 u8     format: 0 = binary datagrams, 1 = JSON datagrams
 *     7    1 u8     flags: bit 0 = IPS_SUB_FLAG_ALL (every marker; id_count must be 0)
 *     8    2 u16    lease_s: seconds the stream should last (>= 1; the daemon may shorten it)
 *    10    2 u16    id_count: marker ids that follow (1..IPS_SUB_MAX_IDS without FLAG_ALL)
 *    12   16 u8[16] cookie: all zero in a first request, else the cookie of the daemon's last reply
 *    28  4*n u32    ids
 *
 * Reply, daemon -> robot: IPS_SUB_REPLY_SIZE bytes, never more than the smallest request, so
 * the daemon cannot amplify traffic towards a forged source address.
 *     0    4 u8[4]  magic: 'I' 'P' 'S' 'A'
 *     4    1 u8     version: 1
 *     5    1 u8     status: IPS_SUB_CHALLENGE | IPS_SUB_ACCEPTED | IPS_SUB_REFUSED_FULL | IPS_SUB_UNSUBSCRIBED
 *     6    2 u16    reserved, 0
 *     8    2 u16    lease_s: the lease granted (ACCEPTED), else 0
 *    10    2 u16    reserved, 0
 *    12   16 u8[16] cookie: to echo in the next request
 *
 * Exchange: a request without a valid cookie gets a CHALLENGE (and nothing else); the same
 * request with that cookie gets ACCEPTED and the stream, sent from the subscription port to the
 * request's source address and port, numbered per subscriber, until the lease ends. Renew
 * before that with the same request and the cookie of the last reply (ACCEPTED carries a fresh
 * one). A cookie is a keyed hash of the source address and port under a daemon secret that
 * changes every 30 s; it is accepted for 30-60 s, then the daemon challenges again. Requests
 * from outside the allowed subnets, malformed ones and ones with a wrong HMAC get no answer;
 * the daemon counts every refusal in its status.
 */
#define IPS_SUB_MAGIC_REQUEST "IPSQ"
#define IPS_SUB_MAGIC_REPLY "IPSA"
#define IPS_SUB_VERSION 1u
#define IPS_SUB_REQUEST_HEADER 28u
#define IPS_SUB_REPLY_SIZE 28u
#define IPS_SUB_COOKIE_SIZE 16u
#define IPS_SUB_MAC_SIZE 32u
#define IPS_SUB_MAX_IDS 64u
#define IPS_SUB_OP_SUBSCRIBE 1u
#define IPS_SUB_OP_UNSUBSCRIBE 2u
#define IPS_SUB_FLAG_ALL 0x01u
#define IPS_SUB_CHALLENGE 1u
#define IPS_SUB_ACCEPTED 2u
#define IPS_SUB_REFUSED_FULL 3u
#define IPS_SUB_UNSUBSCRIBED 4u

#ifdef __cplusplus
}
#pragma GCC diagnostic pop
#endif

#endif /* IPS_WIRE_H */
