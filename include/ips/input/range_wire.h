/* The range input, binary form: one UDP datagram per *firing* of a ranging tag, sent to ipsd by
 * the robot that carries the tag (or by a bridge for its UWB / ultrasound module). The daemon's
 * side is documented in docs/ranging.md ("The range input").
 *
 * Plain C99 like ips/output/wire.h, whose little-endian byte helpers (ips_wire_get_* /
 * ips_wire_put_*) it uses: a sender includes both headers. Every multi-byte field is
 * LITTLE-ENDIAN; floats are IEEE-754 binary32.
 *
 * A firing is one ranging round of one tag: every range in a datagram was measured in that
 * round, and the daemon never combines ranges of different firings into one fix (Petkovic et
 * al. lost most of their moving accuracy by mixing ranges of bursts they could not tell apart).
 * A sender that ranges to its references one after another sends them as one firing only if
 * they were measured within a few milliseconds.
 *
 * Datagram = header (IPS_RANGE_HEADER_SIZE bytes) + entry_count entries of entry_size bytes
 * each, then, only when the daemon's `ranging.psk` is set, IPS_RANGE_MAC_SIZE bytes of
 * HMAC-SHA256(psk, every byte before it). A receiver steps through the entries by entry_size
 * from the datagram: a later minor revision may append fields to an entry.
 *
 * Header, 40 bytes:
 *   off size type  field
 *     0    4 u8[4] magic: the ASCII bytes 'I' 'P' 'S' 'R'
 *     4    1 u8    version: 1
 *     5    1 u8    flags: bit 0 = IPS_RANGE_FLAG_ODOMETRY (odometry_m / odometry_sigma_m are
 *                  measured); other bits 0
 *     6    2 u16   entry_count: 1 .. IPS_RANGE_MAX_ENTRIES
 *     8    4 u32   tag: the ranging tag's id (< 2^31), as in the daemon's ranging.tags
 *    12    4 u32   firing: the tag's firing counter, +1 per firing (wraps at 2^32). The daemon
 *                  drops a firing number it has already taken from this tag (a duplicate).
 *    16    8 i64   firing_realtime_ns: when the ranges were measured, on the sender's
 *                  CLOCK_REALTIME (keep it synchronised: NTP, chrony, PTP). 0 = not known: the
 *                  daemon then stamps the firing with the time it received it, and a delayed
 *                  datagram is placed late by its delay.
 *    24    2 u16   entry_size: bytes per entry (12 in version 1)
 *    26    2 u16   reserved, 0
 *    28    4 f32   odometry_m: distance the tag travelled since its previous firing, metres
 *                  (>= 0; a range to its own previous position); 0 without the flag
 *    32    4 f32   odometry_sigma_m: 1-sigma of odometry_m, metres; 0 without the flag
 *    36    4 u32   reserved, 0
 *
 * Entry, 12 bytes:
 *   off size type  field
 *     0    4 u32   reference: a fixed anchor's id (ranging.anchors[].id), or, with bit 31 set
 *                  (IPS_RANGE_REF_TAG), another tag's id in bits 0-30 (a robot acting as a
 *                  mobile anchor); at most once per firing
 *     4    4 f32   range_m: measured distance, metres, finite, 0 .. IPS_RANGE_MAX_RANGE_M
 *     8    4 f32   sigma_m: its 1-sigma, metres, finite, >= 0; 0 = the anchor's configured sigma
 *
 * A datagram that breaks any rule above (size, magic, version, unknown flag bits, counts, a
 * repeated reference, a value out of range) is refused whole and counted as malformed; the
 * daemon's other refusals (not in `allow`, wrong key, over the rate, unknown tag or anchor,
 * duplicate, too old) are in docs/ranging.md.
 */
#ifndef IPS_RANGE_WIRE_H
#define IPS_RANGE_WIRE_H

#include "ips/output/wire.h"

#define IPS_RANGE_MAGIC "IPSR"
#define IPS_RANGE_VERSION 1u
#define IPS_RANGE_FLAG_ODOMETRY 0x01u
#define IPS_RANGE_HEADER_SIZE 40u
#define IPS_RANGE_ENTRY_SIZE 12u
#define IPS_RANGE_MAC_SIZE 32u
#define IPS_RANGE_MAX_ENTRIES 64u
#define IPS_RANGE_MAX_RANGE_M 10000.0f
#define IPS_RANGE_REF_TAG 0x80000000u

/* Header field offsets. */
#define IPS_RANGE_OFF_MAGIC 0u
#define IPS_RANGE_OFF_VERSION 4u
#define IPS_RANGE_OFF_FLAGS 5u
#define IPS_RANGE_OFF_ENTRY_COUNT 6u
#define IPS_RANGE_OFF_TAG 8u
#define IPS_RANGE_OFF_FIRING 12u
#define IPS_RANGE_OFF_FIRING_REALTIME 16u
#define IPS_RANGE_OFF_ENTRY_SIZE 24u
#define IPS_RANGE_OFF_RESERVED 26u
#define IPS_RANGE_OFF_ODOMETRY 28u
#define IPS_RANGE_OFF_ODOMETRY_SIGMA 32u
#define IPS_RANGE_OFF_RESERVED2 36u

/* Entry field offsets. */
#define IPS_RANGE_ENTRY_REFERENCE 0u
#define IPS_RANGE_ENTRY_RANGE 4u
#define IPS_RANGE_ENTRY_SIGMA 8u

#endif /* IPS_RANGE_WIRE_H */
