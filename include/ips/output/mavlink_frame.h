// MAVLink 2 framing and the three messages ipsd sends (HEARTBEAT, VISION_POSITION_ESTIMATE,
// ODOMETRY), written from the protocol specification (mavlink.io "Serialization"; message
// definitions of common.xml / minimal.xml), no generated headers.
//
// Frame: 0xFD, payload length, incompat flags, compat flags, sequence, system id, component id,
// message id (24-bit little-endian), payload, CRC-16/MCRF4XX (little-endian) over every byte
// after 0xFD and then the message's CRC_EXTRA byte. Payload: fields little-endian, base fields
// sorted by type size (8-byte types first, stable among equal sizes), then the extension fields
// in declaration order; trailing zero bytes are removed (at least one byte stays).
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

namespace ips::mavlink {

inline constexpr std::uint8_t kMagicV2 = 0xFD;
inline constexpr std::size_t kHeaderSize = 10;  ///< 0xFD .. message id
inline constexpr std::size_t kChecksumSize = 2;

inline constexpr std::uint32_t kMsgHeartbeat = 0;
inline constexpr std::uint32_t kMsgVisionPositionEstimate = 102;
inline constexpr std::uint32_t kMsgOdometry = 331;
/// CRC_EXTRA: a hash of the message's name and base fields (see the tests, which recompute them).
inline constexpr std::uint8_t kCrcExtraHeartbeat = 50;
inline constexpr std::uint8_t kCrcExtraVisionPositionEstimate = 158;
inline constexpr std::uint8_t kCrcExtraOdometry = 91;

// Enum values used (common.xml / minimal.xml).
inline constexpr std::uint8_t kMavTypeOnboardController = 18;  ///< MAV_TYPE_ONBOARD_CONTROLLER
inline constexpr std::uint8_t kMavAutopilotInvalid = 8;        ///< MAV_AUTOPILOT_INVALID: not a flight controller
inline constexpr std::uint8_t kMavStateActive = 4;             ///< MAV_STATE_ACTIVE
inline constexpr std::uint8_t kMavFrameBodyFrd = 12;           ///< MAV_FRAME_BODY_FRD
inline constexpr std::uint8_t kMavFrameLocalFrd = 20;          ///< MAV_FRAME_LOCAL_FRD
inline constexpr std::uint8_t kMavEstimatorTypeMocap = 6;      ///< MAV_ESTIMATOR_TYPE_MOCAP
inline constexpr std::uint8_t kMavCompIdVisualInertialOdometry = 197;

/// CRC-16/MCRF4XX (the MAVLink "X.25" checksum): poly 0x1021 reflected, init 0xFFFF, no final xor.
std::uint16_t crc_accumulate(std::uint8_t byte, std::uint16_t crc);
std::uint16_t crc16(std::span<const std::uint8_t> bytes, std::uint16_t crc = 0xFFFF);

/// Appends little-endian fields to a payload.
class PayloadWriter {
 public:
  void u8(std::uint8_t v) { bytes_.push_back(v); }
  void i8(std::int8_t v) { bytes_.push_back(static_cast<std::uint8_t>(v)); }
  void u32(std::uint32_t v);
  void u64(std::uint64_t v);
  void f32(float v);
  const std::vector<std::uint8_t>& bytes() const { return bytes_; }

 private:
  std::vector<std::uint8_t> bytes_;
};

/// A complete MAVLink 2 frame (unsigned) around `payload` (the full, untruncated payload).
std::vector<std::uint8_t> frame(std::uint32_t msgid, std::uint8_t crc_extra, std::uint8_t sequence,
                                std::uint8_t system_id, std::uint8_t component_id,
                                std::span<const std::uint8_t> payload);

struct Heartbeat {
  std::uint32_t custom_mode = 0;
  std::uint8_t type = kMavTypeOnboardController;
  std::uint8_t autopilot = kMavAutopilotInvalid;
  std::uint8_t base_mode = 0;
  std::uint8_t system_status = kMavStateActive;
  std::uint8_t mavlink_version = 3;
};

/// Pose in a local NED/FRD frame; angles in radians.
struct VisionPositionEstimate {
  std::uint64_t usec = 0;
  float x = 0, y = 0, z = 0, roll = 0, pitch = 0, yaw = 0;
  std::array<float, 21> covariance{};  ///< upper triangle of the 6x6 pose covariance, row-major
  std::uint8_t reset_counter = 0;
};

struct Odometry {
  std::uint64_t time_usec = 0;
  float x = 0, y = 0, z = 0;
  std::array<float, 4> q{1, 0, 0, 0};  ///< w, x, y, z
  float vx = 0, vy = 0, vz = 0, rollspeed = 0, pitchspeed = 0, yawspeed = 0;
  std::array<float, 21> pose_covariance{};
  std::array<float, 21> velocity_covariance{};
  std::uint8_t frame_id = kMavFrameLocalFrd;
  std::uint8_t child_frame_id = kMavFrameBodyFrd;
  std::uint8_t reset_counter = 0;
  std::uint8_t estimator_type = kMavEstimatorTypeMocap;
  std::int8_t quality = 0;  ///< percent; 0 = unknown
};

/// Full (untruncated) payloads in wire order.
std::vector<std::uint8_t> payload(const Heartbeat& m);
std::vector<std::uint8_t> payload(const VisionPositionEstimate& m);
std::vector<std::uint8_t> payload(const Odometry& m);

std::vector<std::uint8_t> frame(const Heartbeat& m, std::uint8_t seq, std::uint8_t sys, std::uint8_t comp);
std::vector<std::uint8_t> frame(const VisionPositionEstimate& m, std::uint8_t seq, std::uint8_t sys, std::uint8_t comp);
std::vector<std::uint8_t> frame(const Odometry& m, std::uint8_t seq, std::uint8_t sys, std::uint8_t comp);

}  // namespace ips::mavlink
