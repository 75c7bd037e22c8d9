#pragma once
// The DDS flags every esfleet program shares (--domain, --profile, --secure), registered in one
// place so that their names, checks and help read the same everywhere.

#include <CLI/CLI.hpp>
#include <string>

namespace esfleet::app {

/// Adds --domain (0-232), --profile FILE and --secure DIR to `app` (a CLI::App or an option
/// group), bound to the given variables.
void add_dds_flags(CLI::App& app, int& domain, std::string& profile, std::string& secure);

}  // namespace esfleet::app
