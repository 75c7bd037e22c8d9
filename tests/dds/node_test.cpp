// Tests of esfleet::dds::Node: participant creation from each shipped Fast DDS profile and clear
// errors for bad domains and bad profile files. Each test uses its own domain id (120-139).

#include "esfleet/dds/node.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace {

namespace fs = std::filesystem;
using esfleet::dds::Node;
using esfleet::dds::NodeOptions;

const std::string kProfiles = ESFLEET_FASTDDS_PROFILE_DIR;

/// The message of the std::runtime_error that constructing a Node with `options` throws.
std::string creation_error(const NodeOptions& options) {
  try {
    Node node(options);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  ADD_FAILURE() << "Node creation did not throw";
  return {};
}

/// A temporary file holding `text`, removed at scope exit.
struct TempFile {
  explicit TempFile(const std::string& name, const std::string& text)
      : path(fs::temp_directory_path() / (name + "-" + std::to_string(getpid()) + ".xml")) {
    std::ofstream(path) << text;
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path, ec);
  }
  fs::path path;
};

TEST(NodeTest, CreatesParticipantWithDefaultQosAndName) {
  Node node({120, ESFLEET_SHM_TEST_PROFILE, "node_test"});
  EXPECT_EQ(node.domain(), 120);
  EXPECT_EQ(node.guid_prefix().size(), 35u) << node.guid_prefix();  // 12 bytes "xx."
}

TEST(NodeTest, RejectsDomainOutOfRange) {
  EXPECT_NE(creation_error({233, "", ""}).find("domain 233 is out of range 0..232"),
            std::string::npos);
  EXPECT_NE(creation_error({-1, "", ""}).find("domain -1"), std::string::npos);
}

TEST(NodeTest, MissingProfileFileIsNamed) {
  const std::string missing = "/nonexistent/esfleet-missing-profile.xml";
  const std::string what = creation_error({121, missing, ""});
  EXPECT_NE(what.find("'" + missing + "'"), std::string::npos) << what;
  EXPECT_NE(what.find("does not exist"), std::string::npos) << what;
}

TEST(NodeTest, MalformedProfileFileIsNamed) {
  TempFile file("esfleet-malformed",
                "<dds><profiles><participant profile_name=\"x\" is_default_profile=\"true\">"
                "<rtps><builtin><bogus_element/></builtin></rtps></participant>");
  const std::string what = creation_error({122, file.path.string(), ""});
  EXPECT_NE(what.find(file.path.string()), std::string::npos) << what;
  EXPECT_NE(what.find("could not load"), std::string::npos) << what;
}

TEST(NodeTest, ProfileWithoutDefaultParticipantIsRejected) {
  TempFile file("esfleet-nodefault",
                R"(<?xml version="1.0" encoding="UTF-8" ?>
<dds xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"><profiles>
  <participant profile_name="esfleet_test_not_default"><rtps/></participant>
</profiles></dds>)");
  const std::string what = creation_error({123, file.path.string(), ""});
  EXPECT_NE(what.find(file.path.string()), std::string::npos) << what;
  EXPECT_NE(what.find("is_default_profile"), std::string::npos) << what;
}

/// Every profile in deploy/fastdds/ loads and yields a participant; loading a second profile in
/// the same process and re-using the first both work (each file's QoS is cached).
class ShippedProfileTest : public ::testing::TestWithParam<std::pair<const char*, int>> {};

TEST_P(ShippedProfileTest, CreatesParticipant) {
  const auto [file, domain] = GetParam();
  const std::string path = kProfiles + "/" + file;
  ASSERT_TRUE(fs::exists(path)) << path;
  Node node({domain, path, std::string("profile_test_") + file});
  EXPECT_FALSE(node.guid_prefix().empty());
  Node other({domain, ESFLEET_SHM_TEST_PROFILE, ""});
  Node again({domain, path, ""});
  EXPECT_NE(again.guid_prefix(), node.guid_prefix());
}

INSTANTIATE_TEST_SUITE_P(Deploy, ShippedProfileTest,
                         ::testing::Values(std::pair{"localhost-udp.xml", 131},
                                           std::pair{"lan-udp.xml", 132},
                                           std::pair{"wifi-initial-peers.xml", 133},
                                           std::pair{"discovery-client.xml", 134}),
                         [](const auto& param_info) {
                           std::string name = param_info.param.first;
                           name = name.substr(0, name.find('.'));
                           for (char& c : name) {
                             if (c == '-') c = '_';
                           }
                           return name;
                         });

}  // namespace
