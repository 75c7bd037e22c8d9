#include "child_args.hpp"

#include <unistd.h>

#include <sstream>
#include <stdexcept>

namespace esfleet::fleet {

namespace {
std::vector<std::string> with(std::vector<std::string> a, const std::vector<std::string>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}
}  // namespace

std::vector<std::string> split_args(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  std::string a;
  while (in >> a) out.push_back(a);
  return out;
}

std::vector<std::string> dds_args(const FleetOptions& o, const std::string& id) {
  std::vector<std::string> flags = {"--domain", std::to_string(o.domain), "--profile", o.profile};
  if (!o.secure.empty()) flags.insert(flags.end(), {"--secure", o.secure_dir_for(id)});
  return flags;
}

std::vector<std::string> leader_argv(const FleetOptions& o, const std::string& bin_dir,
                                     bool resume) {
  std::vector<std::string> argv = {bin_dir + "/esfleet-leader",
                                   "--log",
                                   o.log,
                                   "--rate",
                                   std::to_string(o.leader_rate),
                                   "--linger",
                                   "-1",
                                   "--out",
                                   o.out + "/leader"};
  if (resume) argv = with(argv, {"--resume", o.out + "/leader"});
  if (o.leader_scans > 0) argv = with(argv, {"--max-scans", std::to_string(o.leader_scans)});
  if (o.contribute) argv = with(argv, {"--accept-contributions"});
  return with(with(argv, dds_args(o, "leader")), split_args(o.leader_args));
}

std::vector<std::string> on_host(const FleetOptions& o, int host, std::vector<std::string> argv) {
  if (o.netns.empty()) return argv;
  // spawn() takes a path: iproute2's `ip` where Debian and others put it.
  std::string ip;
  for (const char* p : {"/usr/sbin/ip", "/sbin/ip", "/usr/bin/ip", "/bin/ip"}) {
    if (access(p, X_OK) == 0) {
      ip = p;
      break;
    }
  }
  if (ip.empty()) throw std::runtime_error("--netns: no 'ip' program (package iproute2)");
  return with({ip, "netns", "exec", "esf-" + o.netns + "-" + std::to_string(host)}, argv);
}

std::vector<std::string> follower_argv(const FleetOptions& o, const std::string& bin_dir, int k) {
  const std::string name = robot_name(k);
  std::vector<std::string> argv = {bin_dir + "/esfleet-follower",
                                   "--scan-topic",
                                   name,
                                   "--robot-id",
                                   name,
                                   "--seed",
                                   std::to_string(o.seed + static_cast<unsigned>(k)),
                                   "--save-map",
                                   o.out + "/" + name,
                                   "--trajectory",
                                   o.out + "/" + name + "/trajectory.txt"};
  if (o.contribute) argv = with(argv, {"--contribute"});
  return with(with(argv, dds_args(o, name)), split_args(o.follower_args));
}

std::vector<std::string> sim_argv(const FleetOptions& o, const std::string& bin_dir) {
  return with(
      with({bin_dir + "/esfleet-sim", "--world", o.world, "--robots", std::to_string(o.robots),
            "--rate", std::to_string(o.rate), "--seed", std::to_string(o.seed)},
           dds_args(o, "sim")),
      split_args(o.sim_args));
}

std::vector<std::string> view_argv(const FleetOptions& o, const std::string& bin_dir) {
  return with(
      with({bin_dir + "/esfleet-view", "--port", std::to_string(o.view_port)}, dds_args(o, "view")),
      split_args(o.view_args));
}

}  // namespace esfleet::fleet
