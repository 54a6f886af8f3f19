// An emulated V4L2 capture device, loaded with LD_PRELOAD into a test process, so that the
// unchanged capture code (ips::V4L2Source, `ips cameras`, ipsd) runs without hardware or a
// kernel module. It intercepts open/close/ioctl/mmap/poll/select for the fake device paths
// only; everything else goes straight to the real libc (dlsym(RTLD_NEXT)).
//
// Configuration: IPS_V4L2_EMU_DEVICES="/dev/video-emu0=/tmp/cam0.conf,/dev/video-emu1=..."
// Each control file holds key=value lines and is re-read whenever it changes (replace it
// atomically with rename()), so a test scripts faults at run time:
//   present=1|0          0 = unplugged: open() fails with ENOENT, ioctls on open fds fail
//                        with ENODEV, poll() reports POLLERR|POLLHUP
//   formats=MJPG,YUYV    pixel formats offered, in ENUM_FMT order
//   sizes=1920x1080,...  discrete frame sizes offered; S_FMT grants the nearest one
//   grant=WxH            S_FMT grants this size whatever was asked
//   fps=30               the frame rate granted by S_PARM and used to pace frames
//   frames=DIR           MJPEG frames: the *.jpg files in DIR, sorted, served in a loop
//   corrupt_every=N      frames with (sequence+1) % N == 0 are truncated (corrupt JPEG)
//   drop_every=N         frames with (sequence+1) % N == 0 are lost (sequence gap)
//   yuyv_padding=B       extra bytes at the end of every YUYV line (bytesperline > 2*width)
//   unsupported_controls=gain,focus_auto,...  controls answered with EINVAL
//   card=NAME, bus=BUS   QUERYCAP strings
// Frame n (n = 0, 1, ...) completes at STREAMON + (n+1)/fps on CLOCK_MONOTONIC, carries
// sequence n and that timestamp, and fills the oldest queued buffer; with no buffer queued
// it is dropped, as a real driver does. YUYV frames hold Y(x, y) = (x + 2y + n) mod 256 and
// U = V = 128, so a test can check every pixel.
#include <dlfcn.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <deque>
#include <filesystem>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

namespace {

template <class Fn>
Fn* next_symbol(const char* name) {
  void* p = dlsym(RTLD_NEXT, name);
  if (p == nullptr) {
    std::fprintf(stderr, "v4l2-emu: dlsym(%s) failed\n", name);
    std::abort();
  }
  return reinterpret_cast<Fn*>(p);
}
#define REAL(fn) static auto* const real_##fn = next_symbol<decltype(::fn)>(#fn)

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "v4l2-emu: %s\n", what.c_str());
  std::abort();
}

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return ts.tv_sec * 1'000'000'000LL + ts.tv_nsec;
}

// Reads a whole file with the real libc, never through our own interposers.
std::optional<std::string> read_file(const std::string& path) {
  REAL(open);
  REAL(close);
  const int fd = real_open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return std::nullopt;
  std::string data;
  char chunk[65536];
  ssize_t n = 0;
  while ((n = ::read(fd, chunk, sizeof chunk)) > 0) data.append(chunk, static_cast<std::size_t>(n));
  real_close(fd);
  return data;
}

struct Size {
  std::uint32_t w = 0, h = 0;
};

Size parse_size(const std::string& s) {
  Size size;
  if (std::sscanf(s.c_str(), "%ux%u", &size.w, &size.h) != 2) die("bad size '" + s + "'");
  return size;
}

std::vector<std::string> split(const std::string& s, char sep) {
  std::vector<std::string> parts;
  std::stringstream in(s);
  for (std::string part; std::getline(in, part, sep);)
    if (!part.empty()) parts.push_back(part);
  return parts;
}

struct Config {
  bool present = true;
  std::vector<std::uint32_t> formats{V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_YUYV};
  std::vector<Size> sizes{{1920, 1080}, {1280, 720}, {640, 480}};
  std::optional<Size> grant;
  double fps = 30;
  std::string frames_dir;
  std::uint64_t corrupt_every = 0, drop_every = 0;
  std::uint32_t yuyv_padding = 0;
  std::vector<std::string> unsupported_controls;
  std::string card = "Emulated Camera", bus = "emu";
};

Config parse_config(const std::string& text, const std::string& path) {
  Config c;
  int line_no = 0;
  for (const std::string& line : split(text, '\n')) {
    ++line_no;
    const auto eq = line.find('=');
    if (line[0] == '#') continue;
    if (eq == std::string::npos) die(path + ":" + std::to_string(line_no) + ": expected key=value");
    const std::string key = line.substr(0, eq), value = line.substr(eq + 1);
    if (key == "present")
      c.present = value == "1";
    else if (key == "formats") {
      c.formats.clear();
      for (const auto& f : split(value, ',')) {
        if (f.size() != 4) die(path + ": bad fourcc '" + f + "'");
        c.formats.push_back(v4l2_fourcc(f[0], f[1], f[2], f[3]));
      }
    } else if (key == "sizes") {
      c.sizes.clear();
      for (const auto& s : split(value, ',')) c.sizes.push_back(parse_size(s));
    } else if (key == "grant")
      c.grant = parse_size(value);
    else if (key == "fps")
      c.fps = std::stod(value);
    else if (key == "frames")
      c.frames_dir = value;
    else if (key == "corrupt_every")
      c.corrupt_every = std::stoull(value);
    else if (key == "drop_every")
      c.drop_every = std::stoull(value);
    else if (key == "yuyv_padding")
      c.yuyv_padding = static_cast<std::uint32_t>(std::stoul(value));
    else if (key == "unsupported_controls")
      c.unsupported_controls = split(value, ',');
    else if (key == "card")
      c.card = value;
    else if (key == "bus")
      c.bus = value;
    else
      die(path + ":" + std::to_string(line_no) + ": unknown key '" + key + "'");
  }
  if (c.formats.empty() || c.sizes.empty() || !(c.fps > 0)) die(path + ": needs formats, sizes, fps > 0");
  return c;
}

struct Device {
  std::string path, canonical, control_path;
  Config config;
  struct timespec mtime {};
  ino_t inode = 0;
  off_t file_size = -1;

  // Re-reads the control file if it changed since the last look.
  void reload() {
    struct stat st {};
    if (::stat(control_path.c_str(), &st) != 0) die("cannot stat control file " + control_path);
    if (st.st_ino == inode && st.st_size == file_size && st.st_mtim.tv_sec == mtime.tv_sec &&
        st.st_mtim.tv_nsec == mtime.tv_nsec)
      return;
    const auto text = read_file(control_path);
    if (!text) die("cannot read control file " + control_path);
    config = parse_config(*text, control_path);
    inode = st.st_ino;
    file_size = st.st_size;
    mtime = st.st_mtim;
  }
};

std::vector<Device>& devices() {
  static std::vector<Device> list = [] {
    std::vector<Device> out;
    const char* env = std::getenv("IPS_V4L2_EMU_DEVICES");
    for (const auto& item : split(env ? env : "", ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) die("IPS_V4L2_EMU_DEVICES: expected path=control_file");
      Device d;
      d.path = item.substr(0, eq);
      d.control_path = item.substr(eq + 1);
      std::error_code ec;
      d.canonical = std::filesystem::weakly_canonical(d.path, ec).string();
      out.push_back(std::move(d));
    }
    return out;
  }();
  return list;
}

Device* find_device(const char* path) {
  if (path == nullptr || devices().empty()) return nullptr;
  for (auto& d : devices())
    if (d.path == path) return &d;
  char resolved[PATH_MAX];  // a /dev/v4l/by-id style symlink to a fake device
  if (::realpath(path, resolved) == nullptr) return nullptr;
  for (auto& d : devices())
    if (d.canonical == resolved) return &d;
  return nullptr;
}

struct Control {
  std::uint32_t id;
  const char* name;
  std::int32_t min, max, def;
};
// What a typical UVC camera offers (exposure in 100 us units, exposure_auto 1 = manual,
// 3 = aperture priority; 0 and 2 are rejected as uvcvideo does).
constexpr std::array<Control, 5> kControls{{
    {V4L2_CID_EXPOSURE_AUTO, "exposure_auto", 0, 3, 3},
    {V4L2_CID_EXPOSURE_ABSOLUTE, "exposure_absolute", 3, 2047, 156},
    {V4L2_CID_GAIN, "gain", 0, 255, 0},
    {V4L2_CID_FOCUS_AUTO, "focus_auto", 0, 1, 1},
    {V4L2_CID_POWER_LINE_FREQUENCY, "power_line_frequency", 0, 2, 1},
}};

struct Buffer {
  enum State { kIdle, kQueued, kDone } state = kIdle;
  std::uint32_t bytesused = 0, sequence = 0;
  std::int64_t timestamp_ns = 0;
};

// One open file description of a fake device.
struct Handle {
  Device* device = nullptr;
  bool nonblock = false;
  v4l2_pix_format fmt{};
  double fps = 0;
  std::map<std::uint32_t, std::int32_t> controls;
  int memfd = -1;
  std::uint8_t* mem = nullptr;
  std::size_t stride = 0;  // bytes between buffers in the memfd (page aligned)
  std::vector<Buffer> buffers;
  std::deque<std::uint32_t> queued, done;
  bool streaming = false;
  std::int64_t t0_ns = 0;
  std::uint64_t next_frame = 0;
  std::vector<std::string> jpegs;

  std::int64_t period_ns() const { return static_cast<std::int64_t>(1e9 / fps); }
  std::int64_t completion_ns(std::uint64_t n) const { return t0_ns + static_cast<std::int64_t>(n + 1) * period_ns(); }
};

constexpr int kMaxFd = 65536;
std::array<std::atomic<bool>, kMaxFd> g_fake{};  // lock-free test for the common, real fds
std::mutex g_mutex;
std::map<int, Handle> g_handles;

bool is_fake(int fd) { return fd >= 0 && fd < kMaxFd && g_fake[static_cast<std::size_t>(fd)].load(); }

// What S_FMT grants: the pixel format if offered (else the first one), the nearest size.
v4l2_pix_format granted_format(const Config& c, std::uint32_t pixfmt, Size want) {
  if (std::find(c.formats.begin(), c.formats.end(), pixfmt) == c.formats.end()) pixfmt = c.formats[0];
  Size size = c.sizes[0];
  auto distance = [&](Size s) {
    return std::labs(static_cast<long>(s.w) - want.w) + std::labs(static_cast<long>(s.h) - want.h);
  };
  for (Size s : c.sizes)
    if (distance(s) < distance(size)) size = s;
  if (c.grant) size = *c.grant;
  v4l2_pix_format f{};
  f.pixelformat = pixfmt;
  f.width = size.w;
  f.height = size.h;
  f.field = V4L2_FIELD_NONE;
  f.colorspace = V4L2_COLORSPACE_SRGB;
  if (pixfmt == V4L2_PIX_FMT_YUYV) {
    f.bytesperline = size.w * 2 + c.yuyv_padding;
    f.sizeimage = f.bytesperline * size.h;
  } else {
    f.sizeimage = size.w * size.h * 2;  // room for any JPEG of this size
  }
  return f;
}

void release_buffers(Handle& h) {
  REAL(close);
  if (h.mem != nullptr) ::munmap(h.mem, h.stride * h.buffers.size());
  if (h.memfd >= 0) real_close(h.memfd);
  h.mem = nullptr;
  h.memfd = -1;
  h.buffers.clear();
  h.queued.clear();
  h.done.clear();
}

int allocate_buffers(Handle& h, std::uint32_t count) {
  REAL(mmap);
  release_buffers(h);
  if (count == 0) return 0;
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  h.stride = (h.fmt.sizeimage + page - 1) / page * page;
  h.memfd = memfd_create("ips-v4l2-emu", MFD_CLOEXEC);
  if (h.memfd < 0 || ftruncate(h.memfd, static_cast<off_t>(h.stride * count)) != 0) return -1;
  void* p = real_mmap(nullptr, h.stride * count, PROT_READ | PROT_WRITE, MAP_SHARED, h.memfd, 0);
  if (p == MAP_FAILED) return -1;
  h.mem = static_cast<std::uint8_t*>(p);
  h.buffers.resize(count);
  return 0;
}

bool load_jpegs(Handle& h) {
  namespace fs = std::filesystem;
  h.jpegs.clear();
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(h.device->config.frames_dir, ec))
    if (entry.path().extension() == ".jpg") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const auto& f : files)
    if (auto data = read_file(f.string())) h.jpegs.push_back(std::move(*data));
  return !h.jpegs.empty();
}

bool every(std::uint64_t n, std::uint64_t period) { return period > 0 && (n + 1) % period == 0; }

void fill(Handle& h, std::uint32_t index, std::uint64_t n) {
  Buffer& b = h.buffers[index];
  std::uint8_t* dst = h.mem + h.stride * index;
  if (h.fmt.pixelformat == V4L2_PIX_FMT_YUYV) {
    for (std::uint32_t y = 0; y < h.fmt.height; ++y) {
      std::uint8_t* row = dst + static_cast<std::size_t>(y) * h.fmt.bytesperline;
      for (std::uint32_t x = 0; x < h.fmt.width; ++x) {
        row[2 * x] = static_cast<std::uint8_t>(x + 2 * y + n);
        row[2 * x + 1] = 128;
      }
    }
    b.bytesused = h.fmt.sizeimage;
  } else {
    const std::string& jpeg = h.jpegs[n % h.jpegs.size()];
    std::size_t len = std::min<std::size_t>(jpeg.size(), h.fmt.sizeimage);
    if (every(n, h.device->config.corrupt_every)) len = len * 6 / 10;  // truncated transfer
    std::memcpy(dst, jpeg.data(), len);
    b.bytesused = static_cast<std::uint32_t>(len);
  }
  b.sequence = static_cast<std::uint32_t>(n);
  b.timestamp_ns = h.completion_ns(n);
  b.state = Buffer::kDone;
  h.done.push_back(index);
}

// Completes every frame that is due by now: each takes the oldest queued buffer, or is
// dropped when none is queued.
void catch_up(Handle& h, std::int64_t now) {
  if (!h.streaming) return;
  const auto completed = static_cast<std::uint64_t>(std::max<std::int64_t>(0, (now - h.t0_ns) / h.period_ns()));
  while (h.next_frame < completed) {
    const std::uint64_t n = h.next_frame++;
    if (every(n, h.device->config.drop_every)) continue;
    if (h.queued.empty()) {
      h.next_frame = completed;
      break;
    }
    const std::uint32_t index = h.queued.front();
    h.queued.pop_front();
    fill(h, index, n);
  }
}

void describe_buffer(const Handle& h, std::uint32_t index, v4l2_buffer& b) {
  const Buffer& buf = h.buffers[index];
  b.index = index;
  b.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  b.memory = V4L2_MEMORY_MMAP;
  b.length = h.fmt.sizeimage;
  b.m.offset = static_cast<std::uint32_t>(h.stride * index);
  b.flags = V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
  if (buf.state == Buffer::kQueued) b.flags |= V4L2_BUF_FLAG_QUEUED;
  if (buf.state == Buffer::kDone) b.flags |= V4L2_BUF_FLAG_DONE;
  b.field = V4L2_FIELD_NONE;
  b.bytesused = buf.bytesused;
  b.sequence = buf.sequence;
  b.timestamp.tv_sec = buf.timestamp_ns / 1'000'000'000;
  b.timestamp.tv_usec = (buf.timestamp_ns % 1'000'000'000) / 1000;
}

void copy_string(std::uint8_t* dst, std::size_t size, const std::string& s) {
  std::snprintf(reinterpret_cast<char*>(dst), size, "%s", s.c_str());
}

// Returns 0 or an errno value. `wait_ns` is set when a blocking DQBUF must wait.
int handle_ioctl(Handle& h, unsigned long request, void* arg, std::int64_t& wait_ns) {
  Config& c = h.device->config;
  if (!c.present) return ENODEV;
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      *cap = {};
      copy_string(cap->driver, sizeof cap->driver, "ips-v4l2-emu");
      copy_string(cap->card, sizeof cap->card, c.card);
      copy_string(cap->bus_info, sizeof cap->bus_info, c.bus);
      cap->version = 0x060100;
      cap->device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;
      cap->capabilities = cap->device_caps | V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_ENUM_FMT: {
      auto* f = static_cast<v4l2_fmtdesc*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || f->index >= c.formats.size()) return EINVAL;
      const std::uint32_t index = f->index;
      *f = {};
      f->index = index;
      f->type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
      f->pixelformat = c.formats[index];
      const bool mjpeg = f->pixelformat == V4L2_PIX_FMT_MJPEG;
      f->flags = mjpeg ? V4L2_FMT_FLAG_COMPRESSED : 0;
      copy_string(f->description, sizeof f->description, mjpeg ? "Motion-JPEG" : "YUYV 4:2:2");
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      auto* s = static_cast<v4l2_frmsizeenum*>(arg);
      if (std::find(c.formats.begin(), c.formats.end(), s->pixel_format) == c.formats.end() ||
          s->index >= c.sizes.size())
        return EINVAL;
      s->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      s->discrete = {c.sizes[s->index].w, c.sizes[s->index].h};
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto* i = static_cast<v4l2_frmivalenum*>(arg);
      if (i->index != 0) return EINVAL;
      const auto den = static_cast<std::uint32_t>(std::lround(c.fps * 1000));
      const std::uint32_t g = std::gcd(1000u, den);
      i->type = V4L2_FRMIVAL_TYPE_DISCRETE;
      i->discrete = {1000 / g, den / g};
      return 0;
    }
    case VIDIOC_G_FMT:
    case VIDIOC_S_FMT:
    case VIDIOC_TRY_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      if (request == VIDIOC_G_FMT) {
        f->fmt.pix = h.fmt;
        return 0;
      }
      if (request == VIDIOC_S_FMT && !h.buffers.empty()) return EBUSY;
      f->fmt.pix = granted_format(c, f->fmt.pix.pixelformat, {f->fmt.pix.width, f->fmt.pix.height});
      if (request == VIDIOC_S_FMT) h.fmt = f->fmt.pix;
      return 0;
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
      auto* p = static_cast<v4l2_streamparm*>(arg);
      if (p->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return EINVAL;
      h.fps = c.fps;  // the one rate this device offers, whatever was asked
      p->parm.capture = {};
      p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      const auto den = static_cast<std::uint32_t>(std::lround(c.fps * 1000));
      const std::uint32_t g = std::gcd(1000u, den);
      p->parm.capture.timeperframe = {1000 / g, den / g};
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      if (r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || r->memory != V4L2_MEMORY_MMAP) return EINVAL;
      if (h.streaming) return EBUSY;
      r->count = std::min<std::uint32_t>(r->count, 32);
      return allocate_buffers(h, r->count) == 0 ? 0 : ENOMEM;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->index >= h.buffers.size()) return EINVAL;
      if (request == VIDIOC_QBUF) {
        if (b->memory != V4L2_MEMORY_MMAP || h.buffers[b->index].state != Buffer::kIdle) return EINVAL;
        h.buffers[b->index].state = Buffer::kQueued;
        h.queued.push_back(b->index);
      }
      describe_buffer(h, b->index, *b);
      return 0;
    }
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || !h.streaming) return EINVAL;
      catch_up(h, now_ns());
      if (h.done.empty()) {
        if (h.queued.empty()) return EINVAL;
        if (h.nonblock) return EAGAIN;
        wait_ns = h.completion_ns(h.next_frame) - now_ns();
        return EAGAIN;
      }
      const std::uint32_t index = h.done.front();
      h.done.pop_front();
      describe_buffer(h, index, *b);
      h.buffers[index].state = Buffer::kIdle;
      b->flags &= ~static_cast<std::uint32_t>(V4L2_BUF_FLAG_DONE);
      return 0;
    }
    case VIDIOC_STREAMON:
      if (h.buffers.empty()) return EINVAL;
      if (h.fmt.pixelformat == V4L2_PIX_FMT_MJPEG && !load_jpegs(h)) {
        std::fprintf(stderr, "v4l2-emu: no *.jpg in frames=%s\n", c.frames_dir.c_str());
        return EIO;
      }
      if (h.fps <= 0) h.fps = c.fps;
      if (!h.streaming) {
        h.streaming = true;
        h.t0_ns = now_ns();
        h.next_frame = 0;
      }
      return 0;
    case VIDIOC_STREAMOFF:
      h.streaming = false;
      h.queued.clear();
      h.done.clear();
      for (auto& b : h.buffers) b.state = Buffer::kIdle;
      return 0;
    case VIDIOC_QUERYCTRL:
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: {
      // v4l2_queryctrl and v4l2_control both start with the control id.
      const std::uint32_t id = *static_cast<std::uint32_t*>(arg);
      const auto it = std::find_if(kControls.begin(), kControls.end(), [&](const Control& k) { return k.id == id; });
      if (it == kControls.end() ||
          std::count(c.unsupported_controls.begin(), c.unsupported_controls.end(), it->name) > 0)
        return EINVAL;
      if (request == VIDIOC_QUERYCTRL) {
        auto* q = static_cast<v4l2_queryctrl*>(arg);
        *q = {};
        q->id = id;
        q->type = it->id == V4L2_CID_FOCUS_AUTO ? V4L2_CTRL_TYPE_BOOLEAN
                  : (it->id == V4L2_CID_EXPOSURE_AUTO || it->id == V4L2_CID_POWER_LINE_FREQUENCY)
                      ? V4L2_CTRL_TYPE_MENU
                      : V4L2_CTRL_TYPE_INTEGER;
        copy_string(q->name, sizeof q->name, it->name);
        q->minimum = it->min;
        q->maximum = it->max;
        q->step = 1;
        q->default_value = it->def;
        return 0;
      }
      auto* ctrl = static_cast<v4l2_control*>(arg);
      if (request == VIDIOC_G_CTRL) {
        ctrl->value = h.controls.count(it->id) ? h.controls[it->id] : it->def;
        return 0;
      }
      if (it->id == V4L2_CID_EXPOSURE_AUTO && ctrl->value != 1 && ctrl->value != 3) return EINVAL;
      h.controls[it->id] = std::clamp(ctrl->value, it->min, it->max);
      return 0;
    }
    default: return ENOTTY;
  }
}

int open_fake(Device& dev, int flags) {
  REAL(open);
  std::lock_guard lock(g_mutex);
  dev.reload();
  if (!dev.config.present) {
    errno = ENOENT;
    return -1;
  }
  const int fd = real_open("/dev/null", O_RDWR | (flags & O_CLOEXEC));  // reserves the fd number
  if (fd < 0) return -1;
  if (fd >= kMaxFd) die("fd number too large");
  Handle h;
  h.device = &dev;
  h.nonblock = (flags & O_NONBLOCK) != 0;
  h.fps = dev.config.fps;
  h.fmt = granted_format(dev.config, dev.config.formats[0], dev.config.sizes[0]);
  g_handles[fd] = std::move(h);
  g_fake[static_cast<std::size_t>(fd)] = true;
  return fd;
}

// Readiness of one fake fd; `wake_ns` is lowered to when it may next become ready.
short poll_fake(int fd, std::int64_t now, std::int64_t& wake_ns) {
  std::lock_guard lock(g_mutex);
  auto it = g_handles.find(fd);
  if (it == g_handles.end()) return POLLNVAL;
  Handle& h = it->second;
  h.device->reload();
  if (!h.device->config.present) return POLLERR | POLLHUP;
  if (!h.streaming || (h.queued.empty() && h.done.empty())) return POLLERR;
  catch_up(h, now);
  if (!h.done.empty()) return POLLIN | POLLRDNORM;
  wake_ns = std::min(wake_ns, h.completion_ns(h.next_frame));
  return 0;
}

mode_t mode_arg(int flags, va_list ap) {
  return (flags & (O_CREAT | O_TMPFILE)) != 0 ? static_cast<mode_t>(va_arg(ap, int)) : 0;
}

}  // namespace

// ---------------------------------------------------------------------------------------
// The interposed libc entry points.
extern "C" {

int open(const char* path, int flags, ...) {
  REAL(open);
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  if (Device* d = find_device(path)) return open_fake(*d, flags);
  return real_open(path, flags, mode);
}

int open64(const char* path, int flags, ...) {
  REAL(open64);
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  if (Device* d = find_device(path)) return open_fake(*d, flags);
  return real_open64(path, flags, mode);
}

int openat(int dirfd, const char* path, int flags, ...) {
  REAL(openat);
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  if (Device* d = (dirfd == AT_FDCWD || path[0] == '/') ? find_device(path) : nullptr) return open_fake(*d, flags);
  return real_openat(dirfd, path, flags, mode);
}

int openat64(int dirfd, const char* path, int flags, ...) {
  REAL(openat64);
  va_list ap;
  va_start(ap, flags);
  const mode_t mode = mode_arg(flags, ap);
  va_end(ap);
  if (Device* d = (dirfd == AT_FDCWD || path[0] == '/') ? find_device(path) : nullptr) return open_fake(*d, flags);
  return real_openat64(dirfd, path, flags, mode);
}

// What open() becomes with -D_FORTIFY_SOURCE (distribution package builds).
int __open_2(const char* path, int flags) { return open(path, flags); }
int __open64_2(const char* path, int flags) { return open64(path, flags); }
int __openat_2(int dirfd, const char* path, int flags) { return openat(dirfd, path, flags); }
int __openat64_2(int dirfd, const char* path, int flags) { return openat64(dirfd, path, flags); }

int close(int fd) {
  REAL(close);
  if (is_fake(fd)) {
    std::lock_guard lock(g_mutex);
    auto it = g_handles.find(fd);
    if (it != g_handles.end()) {
      release_buffers(it->second);  // client mappings stay valid until munmap, as in the kernel
      g_handles.erase(it);
    }
    g_fake[static_cast<std::size_t>(fd)] = false;
  }
  return real_close(fd);
}

int ioctl(int fd, unsigned long request, ...) noexcept {
  REAL(ioctl);
  va_list ap;
  va_start(ap, request);
  void* arg = va_arg(ap, void*);
  va_end(ap);
  if (!is_fake(fd)) return real_ioctl(fd, request, arg);
  for (;;) {
    std::int64_t wait_ns = -1;
    int err = 0;
    {
      std::lock_guard lock(g_mutex);
      auto it = g_handles.find(fd);
      if (it == g_handles.end()) {
        err = EBADF;
      } else {
        it->second.device->reload();
        err = handle_ioctl(it->second, request, arg, wait_ns);
      }
    }
    if (err == 0) return 0;
    if (wait_ns < 0) {
      errno = err;
      return -1;
    }
    // Blocking DQBUF: wait for the next frame, re-checking the control file meanwhile.
    const timespec ts{0, std::clamp<std::int64_t>(wait_ns, 100'000, 20'000'000)};
    nanosleep(&ts, nullptr);
  }
}

void* mmap(void* addr, size_t length, int prot, int flags, int fd, off_t offset) noexcept {
  REAL(mmap);
  if (!is_fake(fd)) return real_mmap(addr, length, prot, flags, fd, offset);
  int memfd = -1;
  {
    std::lock_guard lock(g_mutex);
    auto it = g_handles.find(fd);
    if (it != g_handles.end() && it->second.device->config.present && it->second.stride > 0 && offset >= 0 &&
        static_cast<std::size_t>(offset) % it->second.stride == 0 &&
        static_cast<std::size_t>(offset) / it->second.stride < it->second.buffers.size() && length <= it->second.stride)
      memfd = it->second.memfd;
  }
  if (memfd < 0) {
    errno = EINVAL;
    return MAP_FAILED;
  }
  return real_mmap(addr, length, prot, flags, memfd, offset);
}

void* mmap64(void* addr, size_t length, int prot, int flags, int fd, off64_t offset) noexcept {
  return mmap(addr, length, prot, flags, fd, static_cast<off_t>(offset));
}

int poll(struct pollfd* fds, nfds_t nfds, int timeout_ms) {
  REAL(poll);
  const bool any_fake = std::any_of(fds, fds + nfds, [](const pollfd& p) { return is_fake(p.fd); });
  if (!any_fake) return real_poll(fds, nfds, timeout_ms);
  const std::int64_t deadline = timeout_ms < 0 ? INT64_MAX : now_ns() + timeout_ms * 1'000'000LL;
  std::vector<pollfd> real_fds;
  for (;;) {
    const std::int64_t now = now_ns();
    std::int64_t wake = std::min(deadline, now + 20'000'000);  // notice control-file changes
    int ready = 0;
    real_fds.clear();
    for (nfds_t i = 0; i < nfds; ++i) {
      fds[i].revents = 0;
      if (is_fake(fds[i].fd)) {
        const short ev = poll_fake(fds[i].fd, now, wake);
        fds[i].revents = static_cast<short>(ev & (fds[i].events | POLLERR | POLLHUP | POLLNVAL));
        ready += fds[i].revents != 0;
      } else {
        real_fds.push_back(fds[i]);
      }
    }
    int real_ready = 0;
    if (!real_fds.empty()) {
      const std::int64_t wait = ready > 0 ? 0 : std::max<std::int64_t>(0, wake - now);
      real_ready = real_poll(real_fds.data(), real_fds.size(), static_cast<int>(wait / 1'000'000));
      if (real_ready < 0) return -1;
      for (nfds_t i = 0, j = 0; i < nfds; ++i)
        if (!is_fake(fds[i].fd)) fds[i].revents = real_fds[j++].revents;
    } else if (ready == 0 && wake > now) {
      const timespec ts{(wake - now) / 1'000'000'000, (wake - now) % 1'000'000'000};
      nanosleep(&ts, nullptr);
    }
    if (ready + real_ready > 0) return ready + real_ready;
    if (now_ns() >= deadline) return 0;
  }
}

int select(int nfds, fd_set* readfds, fd_set* writefds, fd_set* exceptfds, struct timeval* timeout) {
  REAL(select);
  bool any_fake = false;
  for (int fd = 0; fd < nfds && !any_fake; ++fd)
    any_fake = is_fake(fd) && ((readfds && FD_ISSET(fd, readfds)) || (exceptfds && FD_ISSET(fd, exceptfds)));
  if (!any_fake) return real_select(nfds, readfds, writefds, exceptfds, timeout);
  std::vector<pollfd> p;
  for (int fd = 0; fd < nfds; ++fd) {
    short events = 0;
    if (readfds && FD_ISSET(fd, readfds)) events |= POLLIN;
    if (writefds && FD_ISSET(fd, writefds)) events |= POLLOUT;
    if (exceptfds && FD_ISSET(fd, exceptfds)) events |= POLLPRI;
    if (events != 0) p.push_back({fd, events, 0});
  }
  const int ms = timeout ? static_cast<int>(timeout->tv_sec * 1000 + timeout->tv_usec / 1000) : -1;
  if (poll(p.data(), p.size(), ms) < 0) return -1;
  int count = 0;
  for (fd_set* set : {readfds, writefds, exceptfds})
    if (set) FD_ZERO(set);
  for (const pollfd& q : p) {
    const bool err = (q.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0;
    auto mark = [&](fd_set* set, short event, bool on_error) {
      if (set && (q.events & event) && ((q.revents & event) || (on_error && err))) {
        FD_SET(q.fd, set);
        ++count;
      }
    };
    mark(readfds, POLLIN, true);
    mark(writefds, POLLOUT, true);
    mark(exceptfds, POLLPRI, false);
  }
  return count;
}

}  // extern "C"
