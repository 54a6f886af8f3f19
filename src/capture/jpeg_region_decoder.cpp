#include "ips/capture/jpeg_region_decoder.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

#include "ips/capture/jpeg_restart.h"
#include "ips/capture/libjpeg_errors.h"

namespace ips {

struct JpegRegionDecoder::Impl {
  jpeg_decompress_struct cinfo{};
  LibjpegErrors err{};
  std::vector<std::pair<int, int>> bands;  // [first, last) rows to decode
  // The restart-marker path (reused frame to frame): the frame's layout, the MCU rows to cut
  // out of it, and the cut.
  JpegRestartLayout layout;
  std::vector<std::pair<int, int>> mcu_rows;
  JpegRowCutter cutter;
  std::vector<std::uint8_t> cut;
  std::string why;  // why the last layout or cut was refused (restart_problem())
};

JpegRegionDecoder::JpegRegionDecoder() : impl_(new Impl) {
  // Warnings are errors, as in JpegDecoder: a half-decoded frame must not reach the detector.
  impl_->cinfo.err = install_libjpeg_errors(impl_->err, true);
  if (setjmp(impl_->err.jump) != 0) {
    delete impl_;
    throw std::runtime_error("libjpeg: jpeg_create_decompress failed");
  }
  jpeg_create_decompress(&impl_->cinfo);
}

JpegRegionDecoder::~JpegRegionDecoder() {
  jpeg_destroy_decompress(&impl_->cinfo);
  delete impl_;
}

bool JpegRegionDecoder::read_size(std::span<const std::uint8_t> jpeg, cv::Size& size) {
  jpeg_decompress_struct& c = impl_->cinfo;
  if (jpeg.size() < 4) {
    error_ = "too short to be a JPEG";
    return false;
  }
  if (setjmp(impl_->err.jump) != 0) {
    error_ = impl_->err.message;
    jpeg_abort_decompress(&c);
    return false;
  }
  jpeg_mem_src(&c, jpeg.data(), static_cast<unsigned long>(jpeg.size()));
  jpeg_read_header(&c, TRUE);
  size = cv::Size(static_cast<int>(c.image_width), static_cast<int>(c.image_height));
  jpeg_abort_decompress(&c);
  return true;
}

bool JpegRegionDecoder::decode(std::span<const std::uint8_t> jpeg, cv::Mat& gray, const std::vector<cv::Rect>& rois) {
  jpeg_decompress_struct& c = impl_->cinfo;
  auto& bands = impl_->bands;
  if (jpeg.size() < 4) {
    error_ = "too short to be a JPEG";
    return false;
  }
  if (setjmp(impl_->err.jump) != 0) {
    error_ = impl_->err.message;
    jpeg_abort_decompress(&c);
    return false;
  }
  jpeg_mem_src(&c, jpeg.data(), static_cast<unsigned long>(jpeg.size()));
  jpeg_read_header(&c, TRUE);
  c.out_color_space = JCS_GRAYSCALE;
  c.dct_method = JDCT_IFAST;  // as JpegDecoder's TJFLAG_FASTDCT: the same pixels
  const int width = static_cast<int>(c.image_width);
  const int height = static_cast<int>(c.image_height);
  gray.create(height, width, CV_8UC1);
  // Rows: the ROIs' row ranges merged into bands; columns: one range covering every ROI.
  bands.clear();
  int x0 = width, x1 = 0;
  for (const auto& r0 : rois) {
    const cv::Rect r = r0 & cv::Rect(0, 0, width, height);
    if (r.empty()) continue;
    bands.emplace_back(r.y, r.y + r.height);
    x0 = std::min(x0, r.x);
    x1 = std::max(x1, r.x + r.width);
  }
  if (rois.empty()) {
    bands.emplace_back(0, height);
    x0 = 0;
    x1 = width;
  }
  std::sort(bands.begin(), bands.end());
  std::size_t n = 0;
  for (std::size_t i = 0; i < bands.size(); ++i) {
    if (n > 0 && bands[i].first <= bands[n - 1].second) {
      bands[n - 1].second = std::max(bands[n - 1].second, bands[i].second);
    } else {
      bands[n++] = bands[i];
    }
  }
  bands.resize(n);
  if (bands.empty()) {
    jpeg_abort_decompress(&c);
    return true;
  }
  if (!rois.empty() && plan_restart_cut(jpeg, width, height)) {
    jpeg_abort_decompress(&c);
    return decode_cut(gray, x0, x1);
  }
  if (!rois.empty()) ++skipped_by_huffman_;
  jpeg_start_decompress(&c);
  JDIMENSION xoff = static_cast<JDIMENSION>(x0);
  JDIMENSION cw = static_cast<JDIMENSION>(x1 - x0);
  if (x0 > 0 || x1 < width) jpeg_crop_scanline(&c, &xoff, &cw);  // widened to whole MCUs
  for (const auto& [first, last] : bands) {
    if (static_cast<int>(c.output_scanline) < first)
      jpeg_skip_scanlines(&c, static_cast<JDIMENSION>(first) - c.output_scanline);
    // Up to an MCU row's worth of rows per call: libjpeg then hands over what one iMCU row
    // decodes in one go instead of a call per row.
    JSAMPROW rows[16];
    while (static_cast<int>(c.output_scanline) < last) {
      const int first_row = static_cast<int>(c.output_scanline);
      const int count = std::min(16, last - first_row);
      for (int i = 0; i < count; ++i) rows[i] = gray.ptr<JSAMPLE>(first_row + i) + xoff;
      jpeg_read_scanlines(&c, rows, static_cast<JDIMENSION>(count));
    }
  }
  // Rows below the last band are never entropy-decoded.
  if (c.output_scanline < c.output_height) {
    jpeg_abort_decompress(&c);
  } else {
    jpeg_finish_decompress(&c);
  }
  return true;
}

const std::string& JpegRegionDecoder::restart_problem() const { return impl_->why; }

bool JpegRegionDecoder::plan_restart_cut(std::span<const std::uint8_t> jpeg, int width, int height) {
  Impl& m = *impl_;
  if (!read_jpeg_restart_layout(jpeg, m.layout, m.why) || m.layout.entry_rows == 0 || m.layout.width != width ||
      m.layout.height != height)
    return false;
  // The bands widened to whole MCU rows at the nearest restart markers around them, merged.
  const int entry = m.layout.entry_rows, mcu_h = m.layout.mcu_height;
  m.mcu_rows.clear();
  for (const auto& [first, last] : m.bands) {
    const int r0 = first / mcu_h / entry * entry;
    const int r1 = std::min(((last + mcu_h - 1) / mcu_h + entry - 1) / entry * entry, m.layout.mcu_rows);
    if (!m.mcu_rows.empty() && r0 <= m.mcu_rows.back().second) {
      m.mcu_rows.back().second = std::max(m.mcu_rows.back().second, r1);
    } else {
      m.mcu_rows.emplace_back(r0, r1);
    }
  }
  // Rows from the top down, as the plain path decodes them: nothing to gain.
  if (m.mcu_rows.size() == 1 && m.mcu_rows[0].first == 0) return false;
  if (!m.cutter.cut(jpeg, m.layout, m.mcu_rows, m.cut, m.why)) {
    ++restart_fallbacks_;
    return false;
  }
  return true;
}

bool JpegRegionDecoder::decode_cut(cv::Mat& gray, int x0, int x1) {
  Impl& m = *impl_;
  jpeg_decompress_struct& c = m.cinfo;
  if (setjmp(m.err.jump) != 0) {
    error_ = m.err.message;
    jpeg_abort_decompress(&c);
    return false;
  }
  jpeg_mem_src(&c, m.cut.data(), static_cast<unsigned long>(m.cut.size()));
  jpeg_read_header(&c, TRUE);
  c.out_color_space = JCS_GRAYSCALE;
  c.dct_method = JDCT_IFAST;
  jpeg_start_decompress(&c);
  int rows_cut = 0;
  for (const auto& [first, last] : m.mcu_rows)
    rows_cut += std::min(last * m.layout.mcu_height, gray.rows) - first * m.layout.mcu_height;
  if (static_cast<int>(c.output_width) != gray.cols || static_cast<int>(c.output_height) != rows_cut) {
    error_ = "the rows cut at restart markers do not decode to their size";
    jpeg_abort_decompress(&c);
    return false;
  }
  JDIMENSION xoff = static_cast<JDIMENSION>(x0);
  JDIMENSION cw = static_cast<JDIMENSION>(x1 - x0);
  if (x0 > 0 || x1 < gray.cols) jpeg_crop_scanline(&c, &xoff, &cw);
  // The cut's rows, range after range, go back to their rows in the frame.
  JSAMPROW rows[16];
  for (const auto& [first, last] : m.mcu_rows) {
    const int top = first * m.layout.mcu_height;
    const int bottom = std::min(last * m.layout.mcu_height, gray.rows);
    for (int y = top; y < bottom;) {
      const int count = std::min(16, bottom - y);
      for (int i = 0; i < count; ++i) rows[i] = gray.ptr<JSAMPLE>(y + i) + xoff;
      y += static_cast<int>(jpeg_read_scanlines(&c, rows, static_cast<JDIMENSION>(count)));
    }
  }
  jpeg_finish_decompress(&c);
  ++entered_at_restarts_;
  return true;
}

}  // namespace ips
