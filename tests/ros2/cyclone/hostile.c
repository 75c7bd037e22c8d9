/* esfleet-ros2-peer hostile: broken LaserScan, Odometry and PoseWithCovarianceStamped messages
 * (then valid scans), for checking that the receiver rejects them and keeps working. */
#define _POSIX_C_SOURCE 200809L
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "peer_common.h"
#include "subcommands.h"

static const char* const kCmd = "hostile";
static const double kPi = 3.14159265358979323846;

void hostile_usage(FILE* f) {
  fprintf(
      f,
      "usage: esfleet-ros2-peer hostile --domain D --scan-topic T --frame LASER\n"
      "         [--odom-topic T2] [--initialpose-topic T3] [--wait-readers N] [--repeat K]\n"
      "         [--period S] [--wait-timeout S] [--odom-frame F] [--base-frame B]\n"
      "         [--map-frame M] [--best-effort] [--settle S] [--linger S]\n"
      "  Once N readers of T matched, publishes each broken message K times, then 5 valid\n"
      "  scans, and prints the count sent per kind as one JSON line:\n"
      "    scan_stamp_backwards     a valid scan, then one stamped 1 s earlier (only the second\n"
      "                             is counted; the first round: 1000.0 s then 999.0 s)\n"
      "    scan_ranges_mismatch     angles say 181 beams, 90 ranges\n"
      "    scan_nan_increment       angle_increment NaN\n"
      "    scan_zero_increment      angle_increment 0\n"
      "    scan_many_beams          20,000 beams, increment 2pi/20000\n"
      "    scan_huge                1,000,000 beams, increment 2pi/1e6\n"
      "    scan_wrong_frame         a valid scan with frame_id \"not_the_laser\"\n"
      "    scan_nan_angle_min       angle_min NaN\n"
      "    odom_nan_quaternion      Odometry with a NaN quaternion        (needs --odom-topic)\n"
      "    initialpose_nan          PoseWithCovarianceStamped with x NaN  (needs "
      "--initialpose-topic)\n"
      "    initialpose_wrong_frame  PoseWithCovarianceStamped in frame \"odom\"\n"
      "  (sent in this order). Valid scans: 180 beams, angle_min -pi/2, increment pi/180,\n"
      "  ranges 1.0 .. 5.0, range_min 0, range_max 81.9, frame LASER; every message is stamped\n"
      "  1000.0 s + 0.1 s per message sent before it (the backwards ones excepted), so the 5\n"
      "  final valid scans are newer than everything earlier.\n"
      "  --domain D              DDS domain id (0..232)\n"
      "  --scan-topic T          LaserScan topic, e.g. rt/robot1/scan\n"
      "  --frame LASER           the valid scans' frame_id\n"
      "  --odom-topic T2         Odometry topic (kinds on it skipped without)\n"
      "  --initialpose-topic T3  PoseWithCovarianceStamped topic (reliable, volatile)\n"
      "  --wait-readers N        readers to wait for on T (default 1); T2, T3: waited for up "
      "to 5 s\n"
      "  --repeat K              each broken kind K times (default 1)\n"
      "  --period S              seconds between messages (default 0.1)\n"
      "  --wait-timeout S        give up waiting for T's readers after S s, exit 1 (default 30)\n"
      "  --odom-frame F, --base-frame B   Odometry frames (default odom, base_link)\n"
      "  --map-frame M           frame of initialpose_nan (default map)\n"
      "  --best-effort           scan/odom writers best-effort (default reliable)\n"
      "  --settle S              wait after matching (default 0.5); --linger S after (default "
      "1)\n");
}

typedef struct {
  dds_entity_t scan_w, odom_w, pose_w;
  const char *scan_topic, *odom_topic, *pose_topic, *frame;
  long sent_total; /* messages sent so far: the stamp clock */
  double period;
  bool failed;
} ctx_t;

static double next_stamp(ctx_t* c) { return 1000.0 + 0.1 * (double)c->sent_total; }

static void pace(ctx_t* c) { sleep_seconds(c->period); }

/* A valid 180-beam scan (ranges in buf, 180 floats). */
static sensor_msgs_msg_dds__LaserScan_ valid_scan(const char* frame, double stamp, float* buf) {
  sensor_msgs_msg_dds__LaserScan_ s;
  memset(&s, 0, sizeof s);
  s.header.stamp = stamp_from_seconds(stamp);
  s.header.frame_id = (char*)frame;
  const double inc = kPi / 180.0;
  s.angle_min = (float)(-kPi / 2.0);
  s.angle_increment = (float)inc;
  s.angle_max = (float)(-kPi / 2.0 + 179.0 * inc);
  s.range_min = 0.0f;
  s.range_max = 81.9f;
  for (int i = 0; i < 180; ++i) buf[i] = (float)(1.0 + 4.0 * (double)i / 179.0);
  s.ranges._maximum = s.ranges._length = 180;
  s.ranges._buffer = buf;
  s.ranges._release = false;
  s.intensities._release = false;
  return s;
}

static bool send_scan(ctx_t* c, const sensor_msgs_msg_dds__LaserScan_* s) {
  if (c->failed || peer_stop) return false;
  if (!write_sample(c->scan_w, s, c->scan_topic)) {
    c->failed = true;
    return false;
  }
  ++c->sent_total;
  pace(c);
  return true;
}

/* `repeat` scans of n_beams readings of 2 m over a full turn, consistent angles; returns how
   many were sent. */
static long send_long_scans(ctx_t* c, const char* frame, float* buf, long n_beams, long repeat) {
  float* ranges = malloc(sizeof(float) * (size_t)n_beams);
  if (ranges == NULL) {
    fprintf(stderr, "esfleet-ros2-peer hostile: out of memory\n");
    c->failed = true;
    return 0;
  }
  for (long i = 0; i < n_beams; ++i) ranges[i] = 2.0f;
  long sent = 0;
  for (long k = 0; k < repeat && !c->failed; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(c), buf);
    const double inc = 2.0 * kPi / (double)n_beams;
    s.angle_min = (float)(-kPi);
    s.angle_increment = (float)inc;
    s.angle_max = (float)(-kPi + ((double)n_beams - 1.0) * inc);
    s.ranges._length = s.ranges._maximum = (uint32_t)n_beams;
    s.ranges._buffer = ranges;
    if (send_scan(c, &s)) ++sent;
  }
  free(ranges);
  return sent;
}

static bool send_pose(ctx_t* c, const char* frame, double x, double stamp) {
  if (c->failed || peer_stop) return false;
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ p;
  memset(&p, 0, sizeof p);
  p.header.stamp = stamp_from_seconds(stamp);
  p.header.frame_id = (char*)frame;
  p.pose.pose.position.x = x;
  p.pose.pose.position.y = 0.0;
  p.pose.pose.orientation = quaternion_of_yaw(0.0);
  p.pose.covariance[0] = p.pose.covariance[7] = 0.25;
  p.pose.covariance[35] = 0.09;
  if (!write_sample(c->pose_w, &p, c->pose_topic)) {
    c->failed = true;
    return false;
  }
  ++c->sent_total;
  pace(c);
  return true;
}

int hostile_main(int argc, char** argv) {
  enum {
    kDomain = 1000,
    kScanTopic,
    kOdomTopic,
    kPoseTopic,
    kFrame,
    kWaitReaders,
    kRepeat,
    kPeriod,
    kWaitTimeout,
    kOdomFrame,
    kBaseFrame,
    kMapFrame,
    kBestEffort,
    kSettle,
    kLinger,
    kHelp
  };
  static const struct option opts[] = {{"domain", required_argument, NULL, kDomain},
                                       {"scan-topic", required_argument, NULL, kScanTopic},
                                       {"odom-topic", required_argument, NULL, kOdomTopic},
                                       {"initialpose-topic", required_argument, NULL, kPoseTopic},
                                       {"frame", required_argument, NULL, kFrame},
                                       {"wait-readers", required_argument, NULL, kWaitReaders},
                                       {"repeat", required_argument, NULL, kRepeat},
                                       {"period", required_argument, NULL, kPeriod},
                                       {"wait-timeout", required_argument, NULL, kWaitTimeout},
                                       {"odom-frame", required_argument, NULL, kOdomFrame},
                                       {"base-frame", required_argument, NULL, kBaseFrame},
                                       {"map-frame", required_argument, NULL, kMapFrame},
                                       {"best-effort", no_argument, NULL, kBestEffort},
                                       {"settle", required_argument, NULL, kSettle},
                                       {"linger", required_argument, NULL, kLinger},
                                       {"help", no_argument, NULL, kHelp},
                                       {NULL, 0, NULL, 0}};
  long domain = -1, wait_readers = 1, repeat = 1;
  const char *scan_topic = NULL, *odom_topic = NULL, *pose_topic = NULL, *frame = NULL;
  const char *odom_frame = "odom", *base_frame = "base_link", *map_frame = "map";
  double period = 0.1, wait_timeout = 30, settle = 0.5, linger = 1;
  bool best_effort = false;
  int opt;
  opterr = 0;
  while ((opt = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    switch (opt) {
      case kDomain:
        domain = parse_long_arg(kCmd, "domain", optarg, 0, 232);
        break;
      case kScanTopic:
        scan_topic = parse_string_arg(kCmd, "scan-topic", optarg);
        break;
      case kOdomTopic:
        odom_topic = parse_string_arg(kCmd, "odom-topic", optarg);
        break;
      case kPoseTopic:
        pose_topic = parse_string_arg(kCmd, "initialpose-topic", optarg);
        break;
      case kFrame:
        frame = parse_string_arg(kCmd, "frame", optarg);
        break;
      case kWaitReaders:
        wait_readers = parse_long_arg(kCmd, "wait-readers", optarg, 0, 1000);
        break;
      case kRepeat:
        repeat = parse_long_arg(kCmd, "repeat", optarg, 1, 100000);
        break;
      case kPeriod:
        period = parse_double_arg(kCmd, "period", optarg, 0, 1e5);
        break;
      case kWaitTimeout:
        wait_timeout = parse_double_arg(kCmd, "wait-timeout", optarg, 0, 1e7);
        break;
      case kOdomFrame:
        odom_frame = parse_string_arg(kCmd, "odom-frame", optarg);
        break;
      case kBaseFrame:
        base_frame = parse_string_arg(kCmd, "base-frame", optarg);
        break;
      case kMapFrame:
        map_frame = parse_string_arg(kCmd, "map-frame", optarg);
        break;
      case kBestEffort:
        best_effort = true;
        break;
      case kSettle:
        settle = parse_double_arg(kCmd, "settle", optarg, 0, 1e7);
        break;
      case kLinger:
        linger = parse_double_arg(kCmd, "linger", optarg, 0, 1e7);
        break;
      case kHelp:
        hostile_usage(stdout);
        return PEER_EXIT_OK;
      default:
        bad_option(kCmd, argv);
    }
  }
  reject_positional(kCmd, argc, argv, optind);
  require_arg(kCmd, "domain", domain >= 0);
  require_arg(kCmd, "scan-topic", scan_topic != NULL);
  require_arg(kCmd, "frame", frame != NULL);

  install_signal_handlers();
  ctx_t c;
  memset(&c, 0, sizeof c);
  c.scan_topic = scan_topic;
  c.odom_topic = odom_topic;
  c.pose_topic = pose_topic;
  c.frame = frame;
  c.period = period;
  const dds_entity_t participant = create_participant_or_exit(domain);
  c.scan_w = create_writer_or_exit(
      participant,
      create_topic_or_exit(participant, &sensor_msgs_msg_dds__LaserScan__desc, scan_topic),
      make_qos(!best_effort, false, 100));
  if (odom_topic != NULL) {
    c.odom_w = create_writer_or_exit(
        participant,
        create_topic_or_exit(participant, &nav_msgs_msg_dds__Odometry__desc, odom_topic),
        make_qos(!best_effort, false, 100));
  }
  if (pose_topic != NULL) {
    c.pose_w = create_writer_or_exit(
        participant,
        create_topic_or_exit(participant, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
                             pose_topic),
        make_qos(true, false, 10));
  }
  if (!wait_for_readers(c.scan_w, wait_readers, wait_timeout)) {
    fprintf(stderr, "esfleet-ros2-peer hostile: %s: fewer than %ld readers matched in %g s\n",
            scan_topic, wait_readers, wait_timeout);
    dds_delete(participant);
    return PEER_EXIT_FAIL;
  }
  const double extra_wait = wait_timeout < 5 ? wait_timeout : 5;
  if (c.odom_w > 0 && !wait_for_readers(c.odom_w, wait_readers, extra_wait)) {
    fprintf(stderr, "esfleet-ros2-peer hostile: warning: %s: fewer than %ld readers matched\n",
            odom_topic, wait_readers);
  }
  if (c.pose_w > 0 && !wait_for_readers(c.pose_w, wait_readers, extra_wait)) {
    fprintf(stderr, "esfleet-ros2-peer hostile: warning: %s: fewer than %ld readers matched\n",
            pose_topic, wait_readers);
  }
  sleep_seconds(settle);

  float buf[181];
  long n_backwards = 0, n_mismatch = 0, n_nan_inc = 0, n_zero_inc = 0, n_wrong_frame = 0,
       n_nan_min = 0, n_odom_nan = 0, n_pose_nan = 0, n_pose_frame = 0, n_valid = 0;

  for (long k = 0; k < repeat; ++k) { /* first: the stamp order starts at 1000.0 */
    const double t = next_stamp(&c);
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, t, buf);
    if (!send_scan(&c, &s)) break;
    s.header.stamp = stamp_from_seconds(t - 1.0);
    if (!send_scan(&c, &s)) break;
    ++n_backwards;
  }
  for (long k = 0; k < repeat; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(&c), buf);
    s.ranges._length = s.ranges._maximum = 90; /* angles still say 181 beams: */
    s.angle_max = (float)(-kPi / 2.0 + 180.0 * (kPi / 180.0));
    if (send_scan(&c, &s)) ++n_mismatch;
  }
  for (long k = 0; k < repeat; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(&c), buf);
    s.angle_increment = NAN;
    if (send_scan(&c, &s)) ++n_nan_inc;
  }
  for (long k = 0; k < repeat; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(&c), buf);
    s.angle_increment = 0.0f;
    if (send_scan(&c, &s)) ++n_zero_inc;
  }
  /* 20,000 beams (80 kB) arrive over UDP; 1,000,000 (4 MB, best-effort to esfleet) may be
     lost in transport when the receiver's socket buffer is smaller. */
  const long n_many = send_long_scans(&c, frame, buf, 20000, repeat);
  const long n_huge = send_long_scans(&c, frame, buf, 1000000, repeat);
  for (long k = 0; k < repeat; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan("not_the_laser", next_stamp(&c), buf);
    if (send_scan(&c, &s)) ++n_wrong_frame;
  }
  for (long k = 0; k < repeat; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(&c), buf);
    s.angle_min = NAN;
    if (send_scan(&c, &s)) ++n_nan_min;
  }
  for (long k = 0; k < repeat && c.odom_w > 0 && !c.failed && !peer_stop; ++k) {
    nav_msgs_msg_dds__Odometry_ o;
    memset(&o, 0, sizeof o);
    o.header.stamp = stamp_from_seconds(next_stamp(&c));
    o.header.frame_id = (char*)odom_frame;
    o.child_frame_id = (char*)base_frame;
    o.pose.pose.position.x = 1.0;
    o.pose.pose.orientation.x = o.pose.pose.orientation.y = NAN;
    o.pose.pose.orientation.z = o.pose.pose.orientation.w = NAN;
    if (!write_sample(c.odom_w, &o, odom_topic)) {
      c.failed = true;
      break;
    }
    ++c.sent_total;
    ++n_odom_nan;
    pace(&c);
  }
  for (long k = 0; k < repeat && c.pose_w > 0; ++k) {
    if (send_pose(&c, map_frame, NAN, next_stamp(&c))) ++n_pose_nan;
  }
  for (long k = 0; k < repeat && c.pose_w > 0; ++k) {
    if (send_pose(&c, "odom", 1.0, next_stamp(&c))) ++n_pose_frame;
  }
  for (int k = 0; k < 5; ++k) {
    sensor_msgs_msg_dds__LaserScan_ s = valid_scan(frame, next_stamp(&c), buf);
    if (send_scan(&c, &s)) ++n_valid;
  }
  const bool interrupted = peer_stop != 0;
  if (!c.failed && !interrupted) sleep_seconds(linger);
  printf(
      "{\"scan_ranges_mismatch\":%ld,\"scan_nan_increment\":%ld,\"scan_zero_increment\":%ld,"
      "\"scan_many_beams\":%ld,\"scan_huge\":%ld,\"scan_stamp_backwards\":%ld,\"scan_wrong_frame\":"
      "%ld,"
      "\"scan_nan_angle_min\":%ld,\"odom_nan_quaternion\":%ld,\"initialpose_nan\":%ld,"
      "\"initialpose_wrong_frame\":%ld,\"valid_scans\":%ld}\n",
      n_mismatch, n_nan_inc, n_zero_inc, n_many, n_huge, n_backwards, n_wrong_frame, n_nan_min,
      n_odom_nan, n_pose_nan, n_pose_frame, n_valid);
  fflush(stdout);
  dds_delete(participant);
  return (c.failed || interrupted) ? PEER_EXIT_FAIL : PEER_EXIT_OK;
}
