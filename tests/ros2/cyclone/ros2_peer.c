/* esfleet-ros2-peer: an independent ROS 2 DDS peer for esfleet's ROS 2 topics, written in C11 over
 * Cyclone DDS with the ROS 2 Humble message types of ros2_msgs.idl (ROS's DDS type names,
 * e.g. "nav_msgs::msg::dds_::OccupancyGrid_"; XCDR1). It shares no code with esfleet, so a
 * test passing against it shows esfleet speaks ROS 2's wire format, not just its own.
 *
 * Topic names are full DDS names ("rt/" + the ROS name). Cyclone runs with its default
 * configuration unless CYCLONEDDS_URI says otherwise. */
#define _POSIX_C_SOURCE 200809L
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "peer_common.h"
#include "subcommands.h"

_Noreturn void bad_option(const char* cmd, char** argv) {
  const char* arg = (optind > 0) ? argv[optind - 1] : "?";
  if (optopt != 0 && arg[0] == '-' && arg[1] == '-' && strchr(arg, '=') == NULL) {
    /* a known option given without its value */
    usage_error(cmd, "option '%s' needs a value", arg);
  }
  usage_error(cmd, "unknown option or bad value: '%s'", arg);
}

typedef struct {
  const char* name;
  int (*run)(int, char**);
  void (*usage)(FILE*);
} subcommand_t;

static const subcommand_t kSubcommands[] = {
    {"map-reader", map_reader_main, map_reader_usage},
    {"scan-writer", scan_writer_main, scan_writer_usage},
    {"hostile", hostile_main, hostile_usage},
    {"pose-reader", pose_reader_main, pose_reader_usage},
    {"initialpose", initialpose_main, initialpose_usage},
};
enum { kNumSubcommands = sizeof kSubcommands / sizeof kSubcommands[0] };

static void usage(FILE* f) {
  fprintf(f,
          "usage: esfleet-ros2-peer SUBCOMMAND [--help | OPTIONS]\n"
          "An independent ROS 2 (Humble) DDS peer over Cyclone DDS, for testing esfleet's ROS 2\n"
          "topics. Topics are DDS names (rt/<ROS name>); every subcommand takes --domain D.\n"
          "Exit codes: 0 success, 1 failure (no data, timeout, DDS error), 2 bad arguments.\n\n");
  for (int i = 0; i < kNumSubcommands; ++i) {
    kSubcommands[i].usage(f);
    fputc('\n', f);
  }
}

int main(int argc, char** argv) {
  if (argc < 2) {
    usage(stderr);
    return PEER_EXIT_USAGE;
  }
  if (strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0 ||
      strcmp(argv[1], "help") == 0) {
    usage(stdout);
    return PEER_EXIT_OK;
  }
  for (int i = 0; i < kNumSubcommands; ++i) {
    if (strcmp(argv[1], kSubcommands[i].name) == 0) {
      /* the subcommand parses argv[1..]: its own name is its argv[0] */
      return kSubcommands[i].run(argc - 1, argv + 1);
    }
  }
  fprintf(stderr, "esfleet-ros2-peer: unknown subcommand '%s' (see esfleet-ros2-peer --help)\n",
          argv[1]);
  return PEER_EXIT_USAGE;
}
