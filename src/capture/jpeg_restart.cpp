#include "ips/capture/jpeg_restart.h"

#include <algorithm>
#include <cstring>
#include <numeric>

namespace ips {
namespace {

constexpr std::uint8_t kMarker = 0xFF;
constexpr std::uint8_t kSoi = 0xD8, kEoi = 0xD9, kSos = 0xDA, kDri = 0xDD;
constexpr std::uint8_t kRst0 = 0xD0, kRst7 = 0xD7;

bool fail(std::string& why, std::string text) {
  why = std::move(text);
  return false;
}

bool is_rst(std::uint8_t code) { return code >= kRst0 && code <= kRst7; }

// Frame headers a region decode cannot enter: everything but baseline (C0) and extended
// Huffman (C1) sequential.
const char* unsupported_frame(std::uint8_t code) {
  switch (code) {
    case 0xC2: return "progressive";
    case 0xC3: return "lossless";
    case 0xC5:
    case 0xC6:
    case 0xC7: return "hierarchical";
    case 0xC9:
    case 0xCA:
    case 0xCB:
    case 0xCD:
    case 0xCE:
    case 0xCF: return "arithmetic-coded";
    default: return nullptr;
  }
}

}  // namespace

bool read_jpeg_restart_layout(std::span<const std::uint8_t> jpeg, JpegRestartLayout& layout, std::string& why) {
  layout = {};
  const std::size_t n = jpeg.size();
  if (n < 4 || jpeg[0] != kMarker || jpeg[1] != kSoi) return fail(why, "not a JPEG (no start-of-image marker)");
  int components = 0, hmax = 0, vmax = 0;
  bool frame = false;
  for (std::size_t p = 2;;) {
    if (p >= n || jpeg[p] != kMarker) return fail(why, "no marker at byte " + std::to_string(p) + " of the headers");
    while (p < n && jpeg[p] == kMarker) ++p;  // fill bytes may precede a marker
    if (p >= n) return fail(why, "the headers end early");
    const std::uint8_t code = jpeg[p++];
    if (code == kEoi) return fail(why, "no scan before the end-of-image marker");
    if (code == 0x01 || (code >= kRst0 && code <= kSoi))
      return fail(why, "a stray marker in the headers at byte " + std::to_string(p - 1));
    if (p + 2 > n) return fail(why, "the headers end early");
    const std::size_t length = (std::size_t{jpeg[p]} << 8) | jpeg[p + 1];
    if (length < 2 || p + length > n)
      return fail(why, "a header segment runs past the end at byte " + std::to_string(p));
    const std::uint8_t* s = jpeg.data() + p + 2;
    const std::size_t size = length - 2;
    if (const char* kind = unsupported_frame(code)) return fail(why, std::string(kind) + " JPEG");
    if (code == 0xC0 || code == 0xC1) {
      if (frame) return fail(why, "two frame headers");
      if (size < 6) return fail(why, "a short frame header");
      if (s[0] != 8) return fail(why, std::to_string(s[0]) + "-bit samples");
      layout.height = (s[1] << 8) | s[2];
      layout.width = (s[3] << 8) | s[4];
      components = s[5];
      if (layout.height == 0) return fail(why, "the height comes later (DNL marker)");
      if (layout.width == 0 || components < 1 || components > 4 || size < 6 + 3 * std::size_t(components))
        return fail(why, "an invalid frame header");
      for (int c = 0; c < components; ++c) {
        const int h = s[6 + 3 * c + 1] >> 4, v = s[6 + 3 * c + 1] & 15;
        if (h < 1 || h > 4 || v < 1 || v > 4) return fail(why, "invalid sampling factors");
        hmax = std::max(hmax, h);
        vmax = std::max(vmax, v);
      }
      layout.height_offset = p + 3;  // length (2 bytes), precision (1 byte), then the height
      frame = true;
    } else if (code == kDri) {
      if (size < 2) return fail(why, "a short restart interval segment");
      layout.restart_interval = (s[0] << 8) | s[1];
    } else if (code == kSos) {
      if (!frame) return fail(why, "a scan before the frame header");
      if (size < 1 || s[0] != components) return fail(why, "a scan of only some of the components");
      layout.scan_offset = p + length;
      break;
    }
    p += length;
  }
  // One component: the MCU is one 8x8 block whatever its sampling factors; several, interleaved:
  // the largest factors' blocks.
  layout.mcu_width = components == 1 ? 8 : 8 * hmax;
  layout.mcu_height = components == 1 ? 8 : 8 * vmax;
  layout.mcus_per_row = (layout.width + layout.mcu_width - 1) / layout.mcu_width;
  layout.mcu_rows = (layout.height + layout.mcu_height - 1) / layout.mcu_height;
  if (layout.restart_interval > 0) {
    // Row r starts a restart interval when r * mcus_per_row is a multiple of the interval.
    layout.entry_rows = layout.restart_interval / std::gcd(layout.restart_interval, layout.mcus_per_row);
  }
  return true;
}

bool JpegRowCutter::cut(std::span<const std::uint8_t> jpeg, const JpegRestartLayout& layout,
                        const std::vector<std::pair<int, int>>& ranges, std::vector<std::uint8_t>& out,
                        std::string& why) {
  const std::int64_t interval = layout.restart_interval;
  if (interval <= 0 || layout.entry_rows <= 0) return fail(why, "no restart markers");
  if (ranges.empty()) return fail(why, "no rows asked for");
  const std::int64_t per_row = layout.mcus_per_row;
  const std::int64_t segments = (per_row * layout.mcu_rows + interval - 1) / interval;
  auto segment_of_row = [&](int row) { return row >= layout.mcu_rows ? segments : row * per_row / interval; };
  int previous = 0;
  for (const auto& [first, last] : ranges) {
    if (first < previous || first >= last || last > layout.mcu_rows || first % layout.entry_rows != 0 ||
        (last % layout.entry_rows != 0 && last != layout.mcu_rows))
      return fail(why, "MCU rows not at restart markers");
    previous = last;
  }
  // Where each segment up to the last one needed starts and ends: the data between restart
  // markers, which must come in order (RST0..RST7 and round again) and number as the layout says.
  const std::int64_t needed = segment_of_row(ranges.back().second);
  const std::size_t n = jpeg.size();
  segment_start_.assign(1, layout.scan_offset);
  segment_end_.clear();
  for (std::size_t p = layout.scan_offset; static_cast<std::int64_t>(segment_end_.size()) < needed;) {
    const void* hit = p < n ? std::memchr(jpeg.data() + p, kMarker, n - p) : nullptr;
    if (hit == nullptr) return fail(why, "the scan ends without its end-of-image marker");
    std::size_t q = static_cast<std::size_t>(static_cast<const std::uint8_t*>(hit) - jpeg.data());
    while (q + 1 < n && jpeg[q + 1] == kMarker) ++q;  // fill bytes
    if (q + 1 >= n) return fail(why, "the scan ends without its end-of-image marker");
    const std::uint8_t code = jpeg[q + 1];
    if (code == 0x00) {  // a stuffed 0xFF data byte
      p = q + 2;
      continue;
    }
    const auto index = static_cast<std::int64_t>(segment_end_.size());
    if (is_rst(code)) {
      if (index + 1 >= segments) return fail(why, "more restart markers than the image has intervals");
      if (code != kRst0 + (index & 7))
        return fail(why, "restart marker " + std::to_string(code - kRst0) + " out of sequence");
      segment_end_.push_back(q);
      segment_start_.push_back(q + 2);
      p = q + 2;
    } else if (code == kEoi) {
      if (index + 1 != segments) return fail(why, "fewer restart markers than the image has intervals");
      segment_end_.push_back(q);
      p = q + 2;
    } else {
      return fail(why, "a marker inside the scan at byte " + std::to_string(q));
    }
  }
  // The cut: the headers with the new height, the needed segments renumbered, end of image.
  int height = 0;
  for (const auto& [first, last] : ranges)
    height += std::min(last * layout.mcu_height, layout.height) - first * layout.mcu_height;
  out.assign(jpeg.begin(), jpeg.begin() + static_cast<std::ptrdiff_t>(layout.scan_offset));
  out[layout.height_offset] = static_cast<std::uint8_t>(height >> 8);
  out[layout.height_offset + 1] = static_cast<std::uint8_t>(height & 0xFF);
  int written = 0;
  for (const auto& [first, last] : ranges) {
    for (std::int64_t s = segment_of_row(first); s < segment_of_row(last); ++s) {
      if (written > 0) {
        out.push_back(kMarker);
        out.push_back(static_cast<std::uint8_t>(kRst0 + ((written - 1) & 7)));
      }
      const auto b = static_cast<std::size_t>(s);
      out.insert(out.end(), jpeg.begin() + static_cast<std::ptrdiff_t>(segment_start_[b]),
                 jpeg.begin() + static_cast<std::ptrdiff_t>(segment_end_[b]));
      ++written;
    }
  }
  out.push_back(kMarker);
  out.push_back(kEoi);
  return true;
}

}  // namespace ips
