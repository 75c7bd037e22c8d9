/* esfleet-ros2-peer subcommands: each parses its own arguments (argv[0] = the subcommand name)
 * and returns the process exit code. */
#ifndef ESFLEET_ROS2_PEER_SUBCOMMANDS_H
#define ESFLEET_ROS2_PEER_SUBCOMMANDS_H

#include <stdio.h>

int map_reader_main(int argc, char** argv);
int scan_writer_main(int argc, char** argv);
int hostile_main(int argc, char** argv);
int pose_reader_main(int argc, char** argv);
int initialpose_main(int argc, char** argv);

void map_reader_usage(FILE* f);
void scan_writer_usage(FILE* f);
void hostile_usage(FILE* f);
void pose_reader_usage(FILE* f);
void initialpose_usage(FILE* f);

/* getopt_long returned '?': names the offending argument and exits 2. */
_Noreturn void bad_option(const char* cmd, char** argv);

#endif
