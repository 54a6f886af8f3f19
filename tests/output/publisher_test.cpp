#include "ips/output/publisher.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "ips/core/error.h"

namespace ips {
namespace {

// A UDP receiver on 127.0.0.1 with a kernel-chosen free port.
struct Receiver {
  int fd = -1;
  std::uint16_t port = 0;
  Receiver() {
    fd = ::socket(AF_INET, SOCK_DGRAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~Receiver() { ::close(fd); }
  // Every datagram that arrives within 200 ms of the previous one.
  std::vector<std::vector<std::uint8_t>> drain() {
    std::vector<std::vector<std::uint8_t>> out;
    pollfd p{fd, POLLIN, 0};
    while (::poll(&p, 1, 200) == 1) {
      std::vector<std::uint8_t> buf(65536);
      const ssize_t n = ::recv(fd, buf.data(), buf.size(), 0);
      if (n < 0) break;
      buf.resize(static_cast<std::size_t>(n));
      out.push_back(std::move(buf));
    }
    return out;
  }
};

OutputConfig to(std::uint16_t port, WireFormat format) {
  OutputConfig o;
  o.kind = OutputConfig::Kind::kUnicast;
  o.address = "127.0.0.1";
  o.port = port;
  o.format = format;
  return o;
}

Datagram update_with(int n, std::uint32_t update_id) {
  Datagram d;
  d.update = update_id;
  d.capture_realtime_ns = 1'000;
  d.capture_monotonic_ns = 2'000;
  for (int i = 0; i < n; ++i) {
    MarkerRecord m;
    m.id = static_cast<std::uint32_t>(i);
    m.x = 0.01 * i;
    d.markers.push_back(m);
  }
  return d;
}

TEST(Publisher, SplitsNumbersAndDeliversBothFormats) {
  Receiver bin, json;
  Publisher pub({to(bin.port, WireFormat::kBinary), to(json.port, WireFormat::kJson)});
  pub.publish(update_with(40, 9));  // binary: 31 + 9 markers
  pub.publish(update_with(0, 10));  // heartbeat
  for (Receiver* r : {&bin, &json}) {
    const auto got = r->drain();
    ASSERT_GE(got.size(), 3u);
    std::uint32_t expected_seq = 0;
    std::vector<std::uint32_t> ids;
    for (const auto& g : got) {
      EXPECT_LE(g.size(), 1199u);
      const Datagram d = decode_datagram(g);
      EXPECT_EQ(d.sequence, expected_seq++);                        // no gaps
      EXPECT_GE(d.publish_realtime_ns, 1'000'000'000'000'000'000);  // stamped with the real clock
      EXPECT_EQ(d.capture_monotonic_ns, 2'000);
      if (d.update == 9) {
        for (const auto& m : d.markers) ids.push_back(m.id);
      } else {
        EXPECT_EQ(d.update, 10u);
        EXPECT_TRUE(d.markers.empty());
      }
    }
    ASSERT_EQ(ids.size(), 40u);
    for (std::uint32_t i = 0; i < 40; ++i) EXPECT_EQ(ids[i], i);
  }
}

TEST(Publisher, SendErrorsAreCountedNotThrown) {
  // Unicast to the broadcast address without SO_BROADCAST: the kernel refuses every sendto (EACCES).
  OutputConfig o = to(9, WireFormat::kBinary);
  o.address = "255.255.255.255";
  Publisher pub({o});
  EXPECT_NO_THROW(pub.publish(update_with(1, 1)));
  EXPECT_NO_THROW(pub.publish(update_with(1, 2)));
  const auto s = pub.stats();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].send_errors, 2u);
  EXPECT_EQ(s[0].datagrams, 0u);
}

TEST(Publisher, InvalidAddressesAreRefusedAtStartNamingTheOutput) {
  OutputConfig m = to(5000, WireFormat::kBinary);
  m.kind = OutputConfig::Kind::kMulticast;  // 127.0.0.1 is no group
  try {
    Publisher p({to(5000, WireFormat::kBinary), m});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("outputs[1].address: '127.0.0.1' is not a multicast group"), std::string::npos)
        << e.what();
  }
  OutputConfig b = to(5000, WireFormat::kBinary);
  b.kind = OutputConfig::Kind::kBroadcast;
  b.address = "lab-pc";
  EXPECT_THROW(Publisher({b}), InputError);
}

}  // namespace
}  // namespace ips
