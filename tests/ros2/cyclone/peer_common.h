/* esfleet-ros2-peer: helpers shared by the subcommands (DDS entities, QoS, time, argument
 * parsing, JSON output). Independent of esfleet: plain C11 over Cyclone DDS. */
#ifndef ESFLEET_ROS2_PEER_COMMON_H
#define ESFLEET_ROS2_PEER_COMMON_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "dds/dds.h"
#include "ros2_msgs.h"

/* Exit codes: 0 success, 1 run-time failure (no data, timeout, DDS error), 2 bad argument. */
enum { PEER_EXIT_OK = 0, PEER_EXIT_FAIL = 1, PEER_EXIT_USAGE = 2 };

/* Set by SIGINT/SIGTERM (install_signal_handlers). */
extern volatile sig_atomic_t peer_stop;
void install_signal_handlers(void);

/* ---- arguments: each reports "<cmd>: --<name>: ..." and exits 2 on a bad value ---- */
_Noreturn void usage_error(const char* cmd, const char* fmt, ...);
long parse_long_arg(const char* cmd, const char* name, const char* text, long min, long max);
double parse_double_arg(const char* cmd, const char* name, const char* text, double min,
                        double max);
/* Rejects an empty string (every name/topic argument must be non-empty). */
const char* parse_string_arg(const char* cmd, const char* name, const char* text);
/* Exits 2 if an option was missing. */
void require_arg(const char* cmd, const char* name, bool given);
/* Exits 2 naming the first positional argument if there is one left at argv[optind]. */
void reject_positional(const char* cmd, int argc, char** argv, int optind);

/* ---- time ---- */
double monotonic_seconds(void);
/* Sleeps up to s seconds, returning early (false) once peer_stop is set. */
bool sleep_seconds(double s);
/* Seconds -> ROS Time: sec = floor(t), nanosec = llround(frac * 1e9), carried at 1e9. */
builtin_interfaces_msg_dds__Time_ stamp_from_seconds(double t);
double stamp_seconds(const builtin_interfaces_msg_dds__Time_* t);
/* sec * 1e9 + nanosec as a total order of stamps. */
int64_t stamp_nanoseconds(const builtin_interfaces_msg_dds__Time_* t);
double yaw_of_quaternion(const geometry_msgs_msg_dds__Quaternion_* q);
/* (0, 0, sin(yaw/2), cos(yaw/2)) */
geometry_msgs_msg_dds__Quaternion_ quaternion_of_yaw(double yaw);

/* ---- DDS ---- */
dds_entity_t create_participant_or_exit(long domain);
dds_entity_t create_topic_or_exit(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                  const char* name);
/* ROS 2-like QoS: reliability, durability (transient-local or volatile), keep-last depth, and
 * data representation XCDR1 only (what rmw_cyclonedds and rmw_fastrtps use). */
dds_qos_t* make_qos(bool reliable, bool transient_local, int32_t depth);
dds_entity_t create_reader_or_exit(dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos);
dds_entity_t create_writer_or_exit(dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos);
/* Waits until the writer has matched at least n readers, up to timeout_s seconds. Returns
 * false on timeout or when interrupted. n <= 0 returns true at once. */
bool wait_for_readers(dds_entity_t writer, long n, double timeout_s);
/* dds_write; on failure prints a message naming the topic and returns false. */
bool write_sample(dds_entity_t writer, const void* sample, const char* what);

/* ---- JSON ---- */
/* A JSON string literal (quotes, escapes, control characters as \u00XX). */
void json_string(FILE* f, const char* s);
/* A stamp as exact decimal seconds (sec.nanosec, 9 digits), e.g. 1134864629.895181894. */
void json_stamp(FILE* f, const builtin_interfaces_msg_dds__Time_* t);
/* Shortest decimal that reads back as the same double; null for NaN/Inf (not JSON). */
void json_double(FILE* f, double v);
/* Shortest decimal that reads back as the same float. */
void json_float(FILE* f, float v);

#endif
