// The status socket as the systemd unit runs ipsd (UMask=0027): the socket is 0660, so members
// of the daemon's group can use `ips status`; someone outside the group gets an error that names
// the group and the command that lets them in.
#include <grp.h>
#include <pwd.h>
#include <sys/stat.h>

#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "plane_model.h"
#include "process_util.h"
#include "published_scene.h"

namespace ips {
namespace {

namespace fs = std::filesystem;

class StatusSocketTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("status_socket_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    fs::permissions(dir_, fs::perms::all & ~(fs::perms::group_write | fs::perms::others_write));
    std::ofstream(dir_ / "scene.yaml") << test::published_scene_with(test::kTwoMovingRobots);
    test::write_plane_model(dir_ / "scene.yaml", dir_ / "model.json");
    std::ofstream(dir_ / "ipsd.yaml") << "cameras:\n  - {name: red, source: synthetic, scene: scene.yaml, fps: 4}\n"
                                      << "markers:\n  ids:\n    1: {height: 0.15}\n"
                                      << "model_file: model.json\n"
                                      << "outputs:\n  - {type: unicast, address: 127.0.0.1, port: "
                                      << test::free_udp_port() << "}\n"
                                      << "status: {interval: 0, socket: " << socket().string() << "}\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path socket() const { return dir_ / "status.sock"; }

  fs::path dir_;
};

TEST_F(StatusSocketTest, IsOpenToTheDaemonsGroupWhateverTheUmask) {
  const mode_t previous = ::umask(0027);  // the unit's UMask, inherited by the daemon
  const fs::path log = dir_ / "ipsd.log";
  const pid_t pid = test::spawn({test::bin("ipsd"), "--config", (dir_ / "ipsd.yaml").string()}, log);
  ::umask(previous);
  const test::ChildGuard guard(pid);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(30 * test::kTimeScale);
  while (!fs::exists(socket()) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  ASSERT_TRUE(fs::exists(socket())) << test::read_file(log);

  struct stat st {};
  ASSERT_EQ(::stat(socket().c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0660u) << std::oct << (st.st_mode & 07777);
  EXPECT_EQ(st.st_gid, ::getgid());  // the daemon's own group (ipsd under systemd)

  // Someone outside the group (nobody, when the test runs as root, as CI does) is told why.
  const passwd* nobody = ::getpwnam("nobody");
  // (Only where nobody can run our ips: a clone under a private directory is out of its reach.)
  const auto as_nobody = [](const std::vector<std::string>& argv, const fs::path& out) {
    std::vector<std::string> all{"/usr/sbin/runuser", "-u", "nobody", "--"};
    all.insert(all.end(), argv.begin(), argv.end());
    return test::run(all, out);
  };
  if (::geteuid() == 0 && nobody != nullptr && fs::exists("/usr/sbin/runuser") &&
      as_nobody({"/usr/bin/test", "-x", test::bin("ips")}, dir_ / "probe.log") == 0) {
    const fs::path out = dir_ / "status_nobody.log";
    EXPECT_EQ(as_nobody({test::bin("ips"), "status", "--socket", socket().string()}, out), 1);
    const std::string text = test::read_file(out);
    const group* g = ::getgrgid(st.st_gid);
    ASSERT_NE(g, nullptr);
    EXPECT_NE(text.find("Permission denied"), std::string::npos) << text;
    EXPECT_NE(text.find(std::string("sudo usermod -aG ") + g->gr_name + " $USER"), std::string::npos) << text;
  }
  // The owner reads it as before.
  const auto status = nlohmann::json::parse(test::read_unix_socket(socket().string()));
  EXPECT_EQ(status["type"], "ipsd.status");
  ::kill(pid, SIGTERM);
  EXPECT_EQ(test::wait_exit(pid, std::chrono::seconds(static_cast<int>(10 * test::kTimeScale))), 0)
      << test::read_file(log);
}

}  // namespace
}  // namespace ips
