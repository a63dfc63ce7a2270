// Bearer tokens: SHA-256 storage, constant-time matching, the first-start admin token.
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "gonio/daemon/rpc/auth.hpp"
#include "gonio/daemon/store/store.hpp"

namespace gonio::daemon {
namespace {

namespace fs = std::filesystem;

TEST(Sha256, KnownVectors) {
  // FIPS 180-4 examples (NIST CSRC "SHA256.pdf"): "abc" and the empty string.
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(Token, IsRandomHex) {
  const auto a = generate_token(), b = generate_token();
  EXPECT_EQ(a.size(), 64u);
  EXPECT_EQ(a.find_first_not_of("0123456789abcdef"), std::string::npos);
  EXPECT_NE(a, b);
}

class AuthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("gonio-auth-test-{}", ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(AuthTest, ConfiguredTokensMapToRoles) {
  Store store(dir_ / "db");
  Auth auth({TokenEntry{"ana", Role::viewer, sha256_hex("viewer-secret")},
             TokenEntry{"tom", Role::technician, sha256_hex("tech-secret")}},
            store);
  const auto v = auth.authenticate("viewer-secret", "tcp");
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(v->name, "ana");
  EXPECT_EQ(v->role, Role::viewer);
  EXPECT_EQ(v->transport, "tcp");
  EXPECT_EQ(auth.authenticate("tech-secret", "http")->role, Role::technician);
  EXPECT_FALSE(auth.authenticate("tech-secreT", "tcp").has_value());
  EXPECT_FALSE(auth.authenticate("", "tcp").has_value());
  EXPECT_FALSE(auth.authenticate(std::string(5000, 'x'), "tcp").has_value());
}

TEST_F(AuthTest, WritesTheAdminTokenOnceWithMode0600) {
  const auto file = dir_ / "admin.token";
  std::string token;
  {
    Store store(dir_ / "db");
    Auth auth({}, store);
    EXPECT_TRUE(auth.ensure_admin_token(file));
    struct stat st {};
    ASSERT_EQ(::stat(file.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0600u);
    std::ifstream in(file);
    std::getline(in, token);
    EXPECT_EQ(auth.authenticate(token, "tcp")->role, Role::admin);
    EXPECT_FALSE(auth.ensure_admin_token(file));  // already there
  }
  // The store keeps only the hash.
  Store store(dir_ / "db");
  for (const auto& t : store.tokens()) EXPECT_NE(t.sha256, token);
  Auth again({}, store);
  EXPECT_FALSE(again.ensure_admin_token(file));
  EXPECT_EQ(again.authenticate(token, "tcp")->name, "admin");
}

TEST_F(AuthTest, NoAdminTokenFileWhenOneIsConfigured) {
  Store store(dir_ / "db");
  Auth auth({TokenEntry{"root", Role::admin, sha256_hex("x")}}, store);
  EXPECT_FALSE(auth.ensure_admin_token(dir_ / "admin.token"));
  EXPECT_FALSE(fs::exists(dir_ / "admin.token"));
}

TEST_F(AuthTest, CreatedTokensCanBeRevoked) {
  Store store(dir_ / "db");
  Auth auth({}, store);
  const auto t = auth.create("robot", Role::technician);
  EXPECT_EQ(auth.authenticate(t, "ws")->name, "robot");
  EXPECT_TRUE(auth.revoke("robot"));
  EXPECT_FALSE(auth.authenticate(t, "ws").has_value());
  EXPECT_FALSE(auth.revoke("robot"));
}

}  // namespace
}  // namespace gonio::daemon
