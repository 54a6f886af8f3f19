// Restart markers in a baseline JPEG: where its entropy-coded data can be entered without
// Huffman-decoding everything before.
//
// A JPEG's entropy-coded data is one bit stream: a decoder that wants the 50th MCU row must
// decode the 49 above it (JpegRegionDecoder measured this at 67-73 % of a whole decode for a
// region near the bottom of a frame). An encoder may cut that stream every `restart_interval`
// MCUs with a restart marker (RST0..RST7, announced by a DRI segment); at each marker the DC
// predictions start over, so the data from a marker on decodes without what precedes it. Where a
// camera's MJPEG frames carry restart markers, a region decode can therefore copy just the
// segments of the MCU rows it needs into a smaller, valid JPEG (same headers, the height
// changed, the markers renumbered) and decode only that: the pixels are the same as a full
// decode's, because every 8x8 block is decoded from the same coefficients.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

namespace ips {

/// What a JPEG's headers say about entering its scan.
struct JpegRestartLayout {
  int width = 0, height = 0;          ///< image size, px
  int mcu_width = 0, mcu_height = 0;  ///< one MCU, px (16 x 16 for 4:2:0)
  int mcus_per_row = 0, mcu_rows = 0;
  int restart_interval = 0;  ///< MCUs between restart markers; 0: the frame has none
  /// The scan can be entered at the start of every this many MCU rows (the rows whose first
  /// MCU begins a restart interval); 0 when it has no restart markers.
  int entry_rows = 0;
  std::size_t height_offset = 0;  ///< where the frame header's 2-byte height is
  std::size_t scan_offset = 0;    ///< first byte of the entropy-coded data
};

/// Reads the markers up to the first scan of `jpeg`. Returns false, with the reason in `why`,
/// for a stream that is not a JPEG or whose scan a region decode cannot enter (progressive,
/// lossless or arithmetic-coded, not 8-bit, a scan of only some of the components, a height
/// given later by a DNL marker). A baseline JPEG without restart markers is read (true) with
/// restart_interval 0.
bool read_jpeg_restart_layout(std::span<const std::uint8_t> jpeg, JpegRestartLayout& layout, std::string& why);

/// Cuts MCU rows out of a JPEG with restart markers.
class JpegRowCutter {
 public:
  /// Writes to `out` a JPEG (the same headers, the restart markers renumbered) whose image is
  /// the MCU rows `ranges` of `jpeg` ([first, last) MCU row pairs, sorted, disjoint, each
  /// `first` a multiple of layout.entry_rows and each `last` one too or the last row) stacked
  /// in order. Returns false, with the reason in `why`, when the scan's restart markers are
  /// not where the layout puts them (a damaged frame: the caller decodes it the slow way,
  /// which then reports the damage).
  bool cut(std::span<const std::uint8_t> jpeg, const JpegRestartLayout& layout,
           const std::vector<std::pair<int, int>>& ranges, std::vector<std::uint8_t>& out, std::string& why);

 private:
  std::vector<std::size_t> segment_start_;  // reused frame to frame
  std::vector<std::size_t> segment_end_;
};

}  // namespace ips
