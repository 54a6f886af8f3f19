// `ips listen` (the real binary) survives a flood of random datagrams and still decodes
// the valid ones that follow, and receives what ipsd's publisher sends to a multicast group
// or a broadcast address (on loopback: the group joined on 127.0.0.1, the broadcast address
// of 127.0.0.0/8).
#include <random>

#include <gtest/gtest.h>

#include "ips/output/packet_codec.h"
#include "ips/output/publisher.h"
#include "process_util.h"

namespace ips {
namespace {

TEST(IpsListen, TenThousandRandomDatagramsAreCountedAndTheValidOnesStillDecode) {
  const auto dir = std::filesystem::temp_directory_path() / ("ips_listen_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto log = dir / "listen.log";
  const std::uint16_t port = test::free_udp_port();
  const pid_t pid = test::spawn({test::bin("ips"), "listen", "--bind", "127.0.0.1:" + std::to_string(port), "--json",
                                 "--count", "5", "--duration", "30"},
                                log);
  const test::ChildGuard guard(pid);
  // Wait until it is listening.
  for (int i = 0; i < 200 && test::read_file(log).find("listening on") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));

  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  to.sin_port = htons(port);
  auto send = [&](const std::vector<std::uint8_t>& b) {
    ::sendto(fd, b.data(), b.size(), 0, reinterpret_cast<sockaddr*>(&to), sizeof to);
  };
  std::mt19937 rng(99);
  Datagram valid;
  valid.markers.resize(2);
  valid.markers[0].id = 5;
  valid.markers[1].id = 6;
  const auto good = encode_binary(valid);
  for (int i = 0; i < 10000; ++i) {
    std::vector<std::uint8_t> b;
    if (i % 2) {  // a valid datagram with damage
      b = good;
      b[rng() % b.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
      if (b[0] == 'I' && b[1] == 'P' && b[2] == 'S' && b[3] == 'D') b.resize(b.size() - 1);  // keep it invalid
    } else {
      b.resize(rng() % 1400);
      for (auto& c : b) c = static_cast<std::uint8_t>(rng());
      if (!b.empty() && b[0] == '{') b[0] = '[';
    }
    send(b);
    if (i % 200 == 199) std::this_thread::sleep_for(std::chrono::milliseconds(5));  // stay within the socket buffer
  }
  for (std::uint32_t s = 0; s < 5; ++s) {
    valid.sequence = s;
    send(encode_binary(valid));
  }
  ::close(fd);
  const auto status = test::wait_exit(pid, std::chrono::seconds(30));
  ASSERT_TRUE(status.has_value());
  EXPECT_EQ(*status, 0);
  const std::string out = test::read_file(log);
  // Five JSON lines, one per valid datagram, and the summary.
  std::size_t lines = 0;
  for (std::size_t p = out.find("{\"type\":\"ips.positions\""); p != std::string::npos;
       p = out.find("{\"type\":\"ips.positions\"", p + 1))
    ++lines;
  EXPECT_EQ(lines, 5u) << out.substr(0, 2000);
  const auto summary = out.find("ips listen: 5 datagrams, ");
  ASSERT_NE(summary, std::string::npos) << out.substr(out.size() > 2000 ? out.size() - 2000 : 0);
  const long malformed = std::stol(out.substr(summary + 25));
  EXPECT_GT(malformed, 9000);  // loopback may drop a few under load, never more than that
  EXPECT_LE(malformed, 10000);
  std::filesystem::remove_all(dir);
}

// Runs `ips listen` with `listen_args`, publishes updates of markers 41 and 42 through a
// Publisher with `output` until listen has taken three, and returns listen's output.
std::string listen_to_publisher(const std::vector<std::string>& listen_args, const OutputConfig& output,
                                const std::string& ready_text) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("ips_listen_pub_" + std::to_string(::getpid()) + "_" + std::to_string(output.port));
  std::filesystem::create_directories(dir);
  const auto log = dir / "listen.log";
  std::vector<std::string> argv = {test::bin("ips"), "listen", "--json", "--count", "3", "--duration", "20"};
  argv.insert(argv.end(), listen_args.begin(), listen_args.end());
  const pid_t pid = test::spawn(argv, log);
  const test::ChildGuard guard(pid);
  for (int i = 0; i < 200 && test::read_file(log).find(ready_text) == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  Publisher pub({output});
  Datagram d;
  d.markers.resize(2);
  d.markers[0].id = 41;
  d.markers[0].x = 1.25;
  d.markers[1].id = 42;
  d.markers[1].y = -0.5;
  std::optional<int> status;
  for (std::uint32_t update = 0; update < 200 && !status; ++update) {
    d.update = update;
    pub.publish(d);
    status = test::wait_exit(pid, std::chrono::milliseconds(50));
  }
  if (!status) status = test::wait_exit(pid, std::chrono::seconds(5));
  EXPECT_TRUE(status.has_value());
  EXPECT_EQ(status.value_or(-1), 0);
  EXPECT_GE(pub.stats().at(0).datagrams, 3u);
  EXPECT_EQ(pub.stats().at(0).send_errors, 0u);
  std::string out = test::read_file(log);
  std::filesystem::remove_all(dir);
  return out;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

TEST(IpsListen, JoinsAMulticastGroupThePublisherSendsTo) {
  const std::uint16_t port = test::free_udp_port();
  // A group in the organisation-local scope, distinct per test process.
  const std::string group = "239.255.71." + std::to_string(1 + ::getpid() % 250);
  OutputConfig out;
  out.kind = OutputConfig::Kind::kMulticast;
  out.address = group;
  out.port = port;
  out.format = WireFormat::kBinary;
  out.interface = "127.0.0.1";
  const std::string text =
      listen_to_publisher({"--group", group + ":" + std::to_string(port), "--interface", "127.0.0.1"}, out, "joined");
  EXPECT_EQ(count_of(text, "{\"type\":\"ips.positions\""), 3u) << text;
  EXPECT_EQ(count_of(text, "\"id\":41"), 3u) << text;
  EXPECT_EQ(count_of(text, "\"id\":42"), 3u) << text;
  EXPECT_NE(text.find("ips listen: 3 datagrams, 0 malformed"), std::string::npos) << text;
}

TEST(IpsListen, ReceivesWhatThePublisherBroadcasts) {
  const std::uint16_t port = test::free_udp_port();
  OutputConfig out;
  out.kind = OutputConfig::Kind::kBroadcast;
  out.address = "127.255.255.255";
  out.port = port;
  out.format = WireFormat::kJson;
  const std::string text = listen_to_publisher({"--bind", "0.0.0.0:" + std::to_string(port)}, out, "listening on");
  EXPECT_EQ(count_of(text, "{\"type\":\"ips.positions\""), 3u) << text;
  EXPECT_EQ(count_of(text, "\"id\":41"), 3u) << text;
  EXPECT_NE(text.find("ips listen: 3 datagrams, 0 malformed"), std::string::npos) << text;
}

TEST(IpsListen, BadGroupOrInterfaceIsAClearErrorWithStatus2) {
  for (const auto& [args, message] : std::vector<std::pair<std::vector<std::string>, std::string>>{
           {{"--group", "10.1.2.3:5005"}, "--group: '10.1.2.3:5005' is not a multicast group"},
           {{"--group", "239.1.2.3:5005", "--interface", "eth0"}, "--interface: 'eth0' is not an IPv4 address"},
           {{"--bind", "127.0.0.1"}, "--bind: expected ADDR:PORT"}}) {
    const auto dir = std::filesystem::temp_directory_path() / ("ips_listen_bad_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    std::vector<std::string> argv = {test::bin("ips"), "listen"};
    argv.insert(argv.end(), args.begin(), args.end());
    const pid_t pid = test::spawn(argv, dir / "log");
    const auto status = test::wait_exit(pid, std::chrono::seconds(10));
    ASSERT_TRUE(status.has_value());
    EXPECT_EQ(*status, 2);
    const std::string text = test::read_file(dir / "log");
    EXPECT_NE(text.find(message), std::string::npos) << text;
    std::filesystem::remove_all(dir);
  }
}

}  // namespace
}  // namespace ips
