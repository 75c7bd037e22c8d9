/* esfleet-ros2-peer scan-writer: a CARMEN log's FLASER scans as sensor_msgs/LaserScan (and
 * optionally nav_msgs/Odometry and tf2_msgs/TFMessage). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "peer_common.h"
#include "subcommands.h"

static const char* const kCmd = "scan-writer";
static const double kPi = 3.14159265358979323846; /* the double nearest pi, as std::numbers::pi */

void scan_writer_usage(FILE* f) {
  fprintf(
      f,
      "usage: esfleet-ros2-peer scan-writer --domain D --log FILE --scan-topic T --frame LASER\n"
      "         [--odom-topic T2] [--odom-frame F] [--base-frame B] [--tf] [--rate HZ]\n"
      "         [--max-scans N] [--wait-readers N] [--wait-timeout S] [--best-effort]\n"
      "         [--linger S] [--range-max R] [--settle S]\n"
      "  Publishes each FLASER line of a plain-text CARMEN log as a LaserScan on T (DDS name,\n"
      "  e.g. rt/robot1/scan): stamp = ipc_timestamp, frame_id = LASER, angle_min = -pi/2,\n"
      "  increment = pi/n (n even) or pi/(n-1) (n odd), range_min 0, range_max R, ranges as\n"
      "  parsed by strtof, no intensities. Other lines, and malformed FLASER lines (reported on\n"
      "  stderr), are skipped.\n"
      "  --domain D         DDS domain id (0..232)\n"
      "  --log FILE         CARMEN log (plain text)\n"
      "  --scan-topic T     LaserScan topic (keep-last 100, volatile)\n"
      "  --frame LASER      the scans' header.frame_id\n"
      "  --odom-topic T2    also an Odometry before each scan, same stamp, pose = odometry\n"
      "  --odom-frame F     Odometry header.frame_id and tf parent (needed with "
      "--odom-topic/--tf)\n"
      "  --base-frame B     Odometry child_frame_id and tf child (needed with --odom-topic/--tf)\n"
      "  --tf               also a TFMessage F -> B on rt/tf (reliable, volatile, keep-last 100)\n"
      "  --rate HZ          scans per second (default 0: as fast as possible, 2 ms apart)\n"
      "  --max-scans N      stop after N scans (default 0: all)\n"
      "  --wait-readers N   first wait for N matched readers of T (default 1; 0 = do not wait)\n"
      "  --wait-timeout S   give up waiting after S seconds, exit 1 (default 30)\n"
      "  --best-effort      scan/odom writers best-effort (default reliable)\n"
      "  --linger S         stay S seconds after the last scan (default 2)\n"
      "  --range-max R      range_max (default 81.9)\n"
      "  --settle S         after matching, wait S seconds so the readers match us too "
      "(default 0.5)\n"
      "  Prints {\"scans_published\":N,\"odom_published\":M,\"tf_published\":K,"
      "\"flaser_skipped\":J} on stdout.\n"
      "  Exit code 0 on success, 1 on no reader / no scan / DDS error / signal, 2 on bad "
      "arguments.\n");
}

/* One parsed FLASER line. */
typedef struct {
  uint32_t n;
  float* ranges;
  double odom_x, odom_y, odom_theta;
  double ipc_timestamp;
} flaser_t;

static bool parse_double_token(const char* s, double* out) {
  char* end = NULL;
  errno = 0;
  const double v = strtod(s, &end);
  if (end == s || *end != '\0' || !isfinite(v)) return false;
  *out = v;
  return true;
}

/* Splits line in place; returns the token count (at most max). */
static size_t tokenize(char* line, char** tokens, size_t max) {
  size_t n = 0;
  char* save = NULL;
  for (char* t = strtok_r(line, " \t\r\n", &save); t != NULL;
       t = strtok_r(NULL, " \t\r\n", &save)) {
    if (n == max) return max + 1;
    tokens[n++] = t;
  }
  return n;
}

enum { kMaxBeams = 10000, kMaxTokens = kMaxBeams + 11 };

/* Returns 1 for a FLASER scan in *out, 0 for another line, -1 for a malformed FLASER line
 * (with the reason in *why). */
static int parse_line(char* line, char** tokens, flaser_t* out, const char** why) {
  const size_t nt = tokenize(line, tokens, kMaxTokens);
  if (nt == 0 || strcmp(tokens[0], "FLASER") != 0) return 0;
  if (nt < 2) {
    *why = "no beam count";
    return -1;
  }
  char* end = NULL;
  errno = 0;
  const long n = strtol(tokens[1], &end, 10);
  if (errno != 0 || end == tokens[1] || *end != '\0' || n < 2 || n > kMaxBeams) {
    *why = "beam count not an integer in [2, 10000]";
    return -1;
  }
  if (nt != (size_t)n + 11) {
    *why = "field count is not n + 11 (n ranges, 6 pose, 3 time fields)";
    return -1;
  }
  for (long i = 0; i < n; ++i) {
    const char* s = tokens[2 + i];
    char* e = NULL;
    const float r = strtof(s, &e);
    if (e == s || *e != '\0' || !isfinite(r) || r < 0.0f) {
      *why = "a range is not a finite number >= 0";
      return -1;
    }
    out->ranges[i] = r;
  }
  const size_t p = 2 + (size_t)n;
  double x, y, theta;
  if (!parse_double_token(tokens[p], &x) || !parse_double_token(tokens[p + 1], &y) ||
      !parse_double_token(tokens[p + 2], &theta) ||
      !parse_double_token(tokens[p + 3], &out->odom_x) ||
      !parse_double_token(tokens[p + 4], &out->odom_y) ||
      !parse_double_token(tokens[p + 5], &out->odom_theta) ||
      !parse_double_token(tokens[p + 6], &out->ipc_timestamp)) {
    *why = "a pose or timestamp field is not a finite number";
    return -1;
  }
  out->n = (uint32_t)n;
  return 1;
}

int scan_writer_main(int argc, char** argv) {
  enum {
    kDomain = 1000,
    kLog,
    kScanTopic,
    kOdomTopic,
    kFrame,
    kOdomFrame,
    kBaseFrame,
    kTf,
    kRate,
    kMaxScans,
    kWaitReaders,
    kWaitTimeout,
    kBestEffort,
    kLinger,
    kRangeMax,
    kSettle,
    kHelp
  };
  static const struct option opts[] = {{"domain", required_argument, NULL, kDomain},
                                       {"log", required_argument, NULL, kLog},
                                       {"scan-topic", required_argument, NULL, kScanTopic},
                                       {"odom-topic", required_argument, NULL, kOdomTopic},
                                       {"frame", required_argument, NULL, kFrame},
                                       {"odom-frame", required_argument, NULL, kOdomFrame},
                                       {"base-frame", required_argument, NULL, kBaseFrame},
                                       {"tf", no_argument, NULL, kTf},
                                       {"rate", required_argument, NULL, kRate},
                                       {"max-scans", required_argument, NULL, kMaxScans},
                                       {"wait-readers", required_argument, NULL, kWaitReaders},
                                       {"wait-timeout", required_argument, NULL, kWaitTimeout},
                                       {"best-effort", no_argument, NULL, kBestEffort},
                                       {"linger", required_argument, NULL, kLinger},
                                       {"range-max", required_argument, NULL, kRangeMax},
                                       {"settle", required_argument, NULL, kSettle},
                                       {"help", no_argument, NULL, kHelp},
                                       {NULL, 0, NULL, 0}};
  long domain = -1, max_scans = 0, wait_readers = 1;
  const char *log_path = NULL, *scan_topic = NULL, *odom_topic = NULL, *frame = NULL,
             *odom_frame = NULL, *base_frame = NULL;
  bool tf = false, best_effort = false;
  double rate = 0, wait_timeout = 30, linger = 2, settle = 0.5, range_max = 81.9;
  int c;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    switch (c) {
      case kDomain:
        domain = parse_long_arg(kCmd, "domain", optarg, 0, 232);
        break;
      case kLog:
        log_path = parse_string_arg(kCmd, "log", optarg);
        break;
      case kScanTopic:
        scan_topic = parse_string_arg(kCmd, "scan-topic", optarg);
        break;
      case kOdomTopic:
        odom_topic = parse_string_arg(kCmd, "odom-topic", optarg);
        break;
      case kFrame:
        frame = parse_string_arg(kCmd, "frame", optarg);
        break;
      case kOdomFrame:
        odom_frame = parse_string_arg(kCmd, "odom-frame", optarg);
        break;
      case kBaseFrame:
        base_frame = parse_string_arg(kCmd, "base-frame", optarg);
        break;
      case kTf:
        tf = true;
        break;
      case kRate:
        rate = parse_double_arg(kCmd, "rate", optarg, 0, 1e6);
        break;
      case kMaxScans:
        max_scans = parse_long_arg(kCmd, "max-scans", optarg, 0, 2000000000L);
        break;
      case kWaitReaders:
        wait_readers = parse_long_arg(kCmd, "wait-readers", optarg, 0, 1000);
        break;
      case kWaitTimeout:
        wait_timeout = parse_double_arg(kCmd, "wait-timeout", optarg, 0, 1e7);
        break;
      case kBestEffort:
        best_effort = true;
        break;
      case kLinger:
        linger = parse_double_arg(kCmd, "linger", optarg, 0, 1e7);
        break;
      case kRangeMax:
        range_max = parse_double_arg(kCmd, "range-max", optarg, 0, 1e30);
        break;
      case kSettle:
        settle = parse_double_arg(kCmd, "settle", optarg, 0, 1e7);
        break;
      case kHelp:
        scan_writer_usage(stdout);
        return PEER_EXIT_OK;
      default:
        bad_option(kCmd, argv);
    }
  }
  reject_positional(kCmd, argc, argv, optind);
  require_arg(kCmd, "domain", domain >= 0);
  require_arg(kCmd, "log", log_path != NULL);
  require_arg(kCmd, "scan-topic", scan_topic != NULL);
  require_arg(kCmd, "frame", frame != NULL);
  if (odom_topic != NULL || tf) {
    require_arg(kCmd, "odom-frame (with --odom-topic or --tf)", odom_frame != NULL);
    require_arg(kCmd, "base-frame (with --odom-topic or --tf)", base_frame != NULL);
  }
  FILE* log = fopen(log_path, "r");
  if (log == NULL) usage_error(kCmd, "--log: cannot open '%s': %s", log_path, strerror(errno));

  install_signal_handlers();
  const dds_entity_t participant = create_participant_or_exit(domain);
  const dds_entity_t scan_t =
      create_topic_or_exit(participant, &sensor_msgs_msg_dds__LaserScan__desc, scan_topic);
  const dds_entity_t scan_w =
      create_writer_or_exit(participant, scan_t, make_qos(!best_effort, false, 100));
  dds_entity_t odom_w = 0, tf_w = 0;
  if (odom_topic != NULL) {
    const dds_entity_t t =
        create_topic_or_exit(participant, &nav_msgs_msg_dds__Odometry__desc, odom_topic);
    odom_w = create_writer_or_exit(participant, t, make_qos(!best_effort, false, 100));
  }
  if (tf) {
    const dds_entity_t t =
        create_topic_or_exit(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf");
    tf_w = create_writer_or_exit(participant, t, make_qos(true, false, 100));
  }

  if (!wait_for_readers(scan_w, wait_readers, wait_timeout)) {
    fprintf(stderr, "esfleet-ros2-peer scan-writer: %s: fewer than %ld readers matched in %g s\n",
            scan_topic, wait_readers, wait_timeout);
    fclose(log);
    dds_delete(participant);
    return PEER_EXIT_FAIL;
  }
  /* The odometry and tf readers (if any) are discovered about as fast: give them a moment. */
  if (odom_w > 0) wait_for_readers(odom_w, 1, 2.0);
  if (tf_w > 0) wait_for_readers(tf_w, 1, 2.0);
  sleep_seconds(settle);

  char** tokens = malloc(sizeof(char*) * (kMaxTokens + 1));
  float* ranges = malloc(sizeof(float) * kMaxBeams);
  if (tokens == NULL || ranges == NULL) {
    fprintf(stderr, "esfleet-ros2-peer scan-writer: out of memory\n");
    return PEER_EXIT_FAIL;
  }
  char* line = NULL;
  size_t cap = 0;
  long line_no = 0, scans = 0, odoms = 0, tfs = 0, skipped = 0;
  bool failed = false;
  const double start = monotonic_seconds();
  while (!peer_stop && (max_scans == 0 || scans < max_scans) && getline(&line, &cap, log) != -1) {
    ++line_no;
    flaser_t fl;
    fl.ranges = ranges;
    const char* why = "";
    const int kind = parse_line(line, tokens, &fl, &why);
    if (kind == 0) continue;
    if (kind < 0) {
      fprintf(stderr, "esfleet-ros2-peer scan-writer: %s:%ld: FLASER line skipped: %s\n", log_path,
              line_no, why);
      ++skipped;
      continue;
    }
    if (rate > 0) {
      if (!sleep_seconds(start + (double)scans / rate - monotonic_seconds())) break;
    } else if (scans > 0) {
      if (!sleep_seconds(0.002)) break;
    }
    const builtin_interfaces_msg_dds__Time_ stamp = stamp_from_seconds(fl.ipc_timestamp);
    geometry_msgs_msg_dds__Pose_ pose;
    pose.position.x = fl.odom_x;
    pose.position.y = fl.odom_y;
    pose.position.z = 0.0;
    pose.orientation = quaternion_of_yaw(fl.odom_theta);

    if (odom_w > 0) {
      nav_msgs_msg_dds__Odometry_ odom;
      memset(&odom, 0, sizeof odom);
      odom.header.stamp = stamp;
      odom.header.frame_id = (char*)odom_frame;
      odom.child_frame_id = (char*)base_frame;
      odom.pose.pose = pose;
      if (!write_sample(odom_w, &odom, odom_topic)) {
        failed = true;
        break;
      }
      ++odoms;
    }
    if (tf_w > 0) {
      geometry_msgs_msg_dds__TransformStamped_ ts;
      memset(&ts, 0, sizeof ts);
      ts.header.stamp = stamp;
      ts.header.frame_id = (char*)odom_frame;
      ts.child_frame_id = (char*)base_frame;
      ts.transform.translation.x = pose.position.x;
      ts.transform.translation.y = pose.position.y;
      ts.transform.translation.z = 0.0;
      ts.transform.rotation = pose.orientation;
      tf2_msgs_msg_dds__TFMessage_ msg;
      msg.transforms._maximum = 1;
      msg.transforms._length = 1;
      msg.transforms._buffer = &ts;
      msg.transforms._release = false;
      if (!write_sample(tf_w, &msg, "rt/tf")) {
        failed = true;
        break;
      }
      ++tfs;
    }

    /* angles exactly as esfleet's CARMEN reader computes them (double, then float) */
    const double beams = (double)fl.n;
    const double angle_min = -kPi / 2.0;
    const double increment = (fl.n % 2 == 1) ? kPi / (beams - 1.0) : kPi / beams;
    sensor_msgs_msg_dds__LaserScan_ scan;
    memset(&scan, 0, sizeof scan);
    scan.header.stamp = stamp;
    scan.header.frame_id = (char*)frame;
    scan.angle_min = (float)angle_min;
    scan.angle_increment = (float)increment;
    scan.angle_max = (float)(angle_min + (beams - 1.0) * increment);
    scan.time_increment = 0.0f;
    scan.scan_time = 0.0f;
    scan.range_min = 0.0f;
    scan.range_max = (float)range_max;
    scan.ranges._maximum = fl.n;
    scan.ranges._length = fl.n;
    scan.ranges._buffer = fl.ranges;
    scan.ranges._release = false;
    scan.intensities._maximum = 0;
    scan.intensities._length = 0;
    scan.intensities._buffer = NULL;
    scan.intensities._release = false;
    if (!write_sample(scan_w, &scan, scan_topic)) {
      failed = true;
      break;
    }
    ++scans;
  }
  const bool interrupted = peer_stop != 0;
  free(line);
  free(tokens);
  free(ranges);
  fclose(log);
  if (scans == 0 && !failed && !interrupted) {
    fprintf(stderr, "esfleet-ros2-peer scan-writer: %s: no valid FLASER line\n", log_path);
  }
  if (!failed && !interrupted) sleep_seconds(linger); /* retransmissions go on meanwhile */
  printf(
      "{\"scans_published\":%ld,\"odom_published\":%ld,\"tf_published\":%ld,"
      "\"flaser_skipped\":%ld}\n",
      scans, odoms, tfs, skipped);
  fflush(stdout);
  dds_delete(participant);
  return (failed || interrupted || scans == 0) ? PEER_EXIT_FAIL : PEER_EXIT_OK;
}
