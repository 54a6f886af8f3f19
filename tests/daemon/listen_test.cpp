// `ips listen` (the real binary) survives a flood of random datagrams and still decodes
// the valid ones that follow.
#include <random>

#include <gtest/gtest.h>

#include "ips/packet_codec.h"
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

}  // namespace
}  // namespace ips
