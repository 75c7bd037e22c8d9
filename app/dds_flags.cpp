#include "app/dds_flags.hpp"

namespace esfleet::app {

void add_dds_flags(CLI::App& app, int& domain, std::string& profile, std::string& secure) {
  app.add_option("--domain", domain, "DDS domain id (0-232)")
      ->check(CLI::Range(0, 232))
      ->capture_default_str();
  app.add_option("--profile", profile,
                 "Fast DDS XML profile (deploy/fastdds/*.xml); default: Fast DDS defaults");
  app.add_option("--secure", secure,
                 "DDS Security: directory with this program's certificates and signed "
                 "governance/permissions (deploy/security/make-fleet-certs.sh, docs/security.md)");
}

}  // namespace esfleet::app
