/* esfleet-ros2-peer pose-reader and initialpose: geometry_msgs/PoseWithCovarianceStamped (and
 * tf2_msgs/TFMessage) in and out. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "peer_common.h"
#include "subcommands.h"

/* ================================ pose-reader ================================ */

void pose_reader_usage(FILE* f) {
  fprintf(
      f,
      "usage: esfleet-ros2-peer pose-reader --domain D --topic T [--tf] [--count N]\n"
      "         [--timeout S] [--out FILE] [--volatile]\n"
      "  Subscribes T as PoseWithCovarianceStamped (reliable, transient-local, keep-last 1) and\n"
      "  with --tf rt/tf (reliable, volatile, keep-last 100) and rt/tf_static (reliable,\n"
      "  transient-local, keep-last 1). One JSON line per sample (per transform for tf), flushed:\n"
      "    {\"kind\":\"pose\",\"stamp\":s,\"frame\":..,\"x\":..,\"y\":..,\"z\":..,\"yaw\":..,"
      "\"cov\":[36]}\n"
      "    {\"kind\":\"tf\",\"static\":b,\"parent\":..,\"child\":..,\"stamp\":s,\"x\":..,"
      "\"y\":..,\"z\":..,\"yaw\":..}\n"
      "  --domain D    DDS domain id (0..232)\n"
      "  --topic T     e.g. rt/robot1/pose\n"
      "  --tf          also rt/tf and rt/tf_static\n"
      "  --count N     exit 0 after N pose samples (default 1)\n"
      "  --timeout S   exit 1 after S seconds (default 30)\n"
      "  --out FILE    write the lines to FILE (default stdout)\n"
      "  --volatile    read T volatile (to match a volatile writer such as `initialpose`)\n");
}

static void print_pose_line(FILE* out, const geometry_msgs_msg_dds__PoseWithCovarianceStamped_* m) {
  const geometry_msgs_msg_dds__Pose_* p = &m->pose.pose;
  fputs("{\"kind\":\"pose\",\"stamp\":", out);
  json_stamp(out, &m->header.stamp);
  fputs(",\"frame\":", out);
  json_string(out, m->header.frame_id);
  fputs(",\"x\":", out);
  json_double(out, p->position.x);
  fputs(",\"y\":", out);
  json_double(out, p->position.y);
  fputs(",\"z\":", out);
  json_double(out, p->position.z);
  fputs(",\"yaw\":", out);
  json_double(out, yaw_of_quaternion(&p->orientation));
  fputs(",\"cov\":[", out);
  for (int i = 0; i < 36; ++i) {
    if (i > 0) fputc(',', out);
    json_double(out, m->pose.covariance[i]);
  }
  fputs("]}\n", out);
  fflush(out);
}

static void print_tf_lines(FILE* out, const tf2_msgs_msg_dds__TFMessage_* m, bool is_static) {
  const uint32_t n = m->transforms._buffer != NULL ? m->transforms._length : 0;
  for (uint32_t i = 0; i < n; ++i) {
    const geometry_msgs_msg_dds__TransformStamped_* t = &m->transforms._buffer[i];
    fprintf(out, "{\"kind\":\"tf\",\"static\":%s,\"parent\":", is_static ? "true" : "false");
    json_string(out, t->header.frame_id);
    fputs(",\"child\":", out);
    json_string(out, t->child_frame_id);
    fputs(",\"stamp\":", out);
    json_stamp(out, &t->header.stamp);
    fputs(",\"x\":", out);
    json_double(out, t->transform.translation.x);
    fputs(",\"y\":", out);
    json_double(out, t->transform.translation.y);
    fputs(",\"z\":", out);
    json_double(out, t->transform.translation.z);
    fputs(",\"yaw\":", out);
    json_double(out, yaw_of_quaternion(&t->transform.rotation));
    fputs("}\n", out);
  }
  fflush(out);
}

enum { kBatch = 32 };

/* Takes everything from a reader; returns the number of valid samples. */
static int drain(dds_entity_t reader, FILE* out, int kind /* 0 pose, 1 tf, 2 tf_static */,
                 long* poses, long max_poses) {
  void* samples[kBatch] = {NULL};
  dds_sample_info_t info[kBatch];
  const int n = dds_take(reader, samples, info, kBatch, kBatch);
  if (n <= 0) return 0;
  int valid = 0;
  for (int i = 0; i < n; ++i) {
    if (!info[i].valid_data) continue;
    ++valid;
    if (kind == 0) {
      if (*poses < max_poses) {
        print_pose_line(out, samples[i]);
        ++*poses;
      }
    } else {
      print_tf_lines(out, samples[i], kind == 2);
    }
  }
  dds_return_loan(reader, samples, n);
  return valid;
}

int pose_reader_main(int argc, char** argv) {
  static const char* const kCmd = "pose-reader";
  enum { kDomain = 1000, kTopic, kTf, kCount, kTimeout, kOut, kVolatile, kHelp };
  static const struct option opts[] = {{"domain", required_argument, NULL, kDomain},
                                       {"topic", required_argument, NULL, kTopic},
                                       {"tf", no_argument, NULL, kTf},
                                       {"count", required_argument, NULL, kCount},
                                       {"timeout", required_argument, NULL, kTimeout},
                                       {"out", required_argument, NULL, kOut},
                                       {"volatile", no_argument, NULL, kVolatile},
                                       {"help", no_argument, NULL, kHelp},
                                       {NULL, 0, NULL, 0}};
  long domain = -1, count = 1;
  const char *topic = NULL, *out_path = NULL;
  bool tf = false, volatile_pose = false;
  double timeout = 30;
  int c;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    switch (c) {
      case kDomain:
        domain = parse_long_arg(kCmd, "domain", optarg, 0, 232);
        break;
      case kTopic:
        topic = parse_string_arg(kCmd, "topic", optarg);
        break;
      case kTf:
        tf = true;
        break;
      case kCount:
        count = parse_long_arg(kCmd, "count", optarg, 1, 2000000000L);
        break;
      case kTimeout:
        timeout = parse_double_arg(kCmd, "timeout", optarg, 0, 1e7);
        break;
      case kOut:
        out_path = parse_string_arg(kCmd, "out", optarg);
        break;
      case kVolatile:
        volatile_pose = true;
        break;
      case kHelp:
        pose_reader_usage(stdout);
        return PEER_EXIT_OK;
      default:
        bad_option(kCmd, argv);
    }
  }
  reject_positional(kCmd, argc, argv, optind);
  require_arg(kCmd, "domain", domain >= 0);
  require_arg(kCmd, "topic", topic != NULL);
  FILE* out = stdout;
  if (out_path != NULL) {
    out = fopen(out_path, "w");
    if (out == NULL) usage_error(kCmd, "--out: cannot open '%s': %s", out_path, strerror(errno));
  }

  install_signal_handlers();
  const dds_entity_t participant = create_participant_or_exit(domain);
  const dds_entity_t waitset = dds_create_waitset(participant);
  dds_entity_t readers[3] = {0, 0, 0};
  readers[0] = create_reader_or_exit(
      participant,
      create_topic_or_exit(participant, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
                           topic),
      make_qos(true, !volatile_pose, 1));
  if (tf) {
    readers[1] = create_reader_or_exit(
        participant, create_topic_or_exit(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf"),
        make_qos(true, false, 100));
    readers[2] = create_reader_or_exit(
        participant,
        create_topic_or_exit(participant, &tf2_msgs_msg_dds__TFMessage__desc, "rt/tf_static"),
        make_qos(true, true, 1));
  }
  for (int i = 0; i < 3; ++i) {
    if (readers[i] > 0) {
      dds_waitset_attach(waitset, dds_create_readcondition(readers[i], DDS_ANY_STATE), 0);
    }
  }
  const double t0 = monotonic_seconds();
  long poses = 0;
  while (!peer_stop && poses < count) {
    const double left = t0 + timeout - monotonic_seconds();
    if (left <= 0) break;
    dds_waitset_wait(waitset, NULL, 0, DDS_MSECS(left < 0.1 ? (int64_t)(left * 1000) + 1 : 100));
    for (int i = 0; i < 3; ++i) {
      if (readers[i] > 0) drain(readers[i], out, i, &poses, count);
    }
  }
  if (poses < count) {
    fprintf(stderr, "esfleet-ros2-peer pose-reader: %s: %ld of %ld pose samples (%s)\n", topic,
            poses, count, peer_stop ? "interrupted" : "timeout");
  }
  if (out != stdout) fclose(out);
  dds_delete(participant);
  return poses >= count ? PEER_EXIT_OK : PEER_EXIT_FAIL;
}

/* ================================ initialpose ================================ */

void initialpose_usage(FILE* f) {
  fprintf(
      f,
      "usage: esfleet-ros2-peer initialpose --domain D --topic T --x X --y Y --yaw A\n"
      "         [--sigma-xy S] [--sigma-yaw S] [--frame F] [--stamp S] [--wait-readers N]\n"
      "         [--wait-timeout S] [--repeat K] [--period S]\n"
      "  Once N readers matched, publishes K PoseWithCovarianceStamped samples on T (reliable,\n"
      "  volatile, keep-last 1), PERIOD apart: position (X, Y, 0), orientation (0, 0,\n"
      "  sin(A/2), cos(A/2)), covariance 0 but [0] = [7] = sigma_xy^2, [35] = sigma_yaw^2.\n"
      "  --domain D          DDS domain id (0..232)\n"
      "  --topic T           e.g. rt/robot1/initialpose\n"
      "  --x X --y Y --yaw A the pose (m, m, rad)\n"
      "  --sigma-xy S        default 0.5\n"
      "  --sigma-yaw S       default 0.3\n"
      "  --frame F           header.frame_id (default map)\n"
      "  --stamp S           header.stamp in seconds (default 0)\n"
      "  --wait-readers N    default 1 (0 = do not wait)\n"
      "  --wait-timeout S    exit 1 if not matched after S seconds (default 30)\n"
      "  --repeat K          default 3\n"
      "  --period S          default 0.5\n");
}

int initialpose_main(int argc, char** argv) {
  static const char* const kCmd = "initialpose";
  enum {
    kDomain = 1000,
    kTopic,
    kX,
    kY,
    kYaw,
    kSigmaXy,
    kSigmaYaw,
    kFrame,
    kStamp,
    kWaitReaders,
    kWaitTimeout,
    kRepeat,
    kPeriod,
    kHelp
  };
  static const struct option opts[] = {{"domain", required_argument, NULL, kDomain},
                                       {"topic", required_argument, NULL, kTopic},
                                       {"x", required_argument, NULL, kX},
                                       {"y", required_argument, NULL, kY},
                                       {"yaw", required_argument, NULL, kYaw},
                                       {"sigma-xy", required_argument, NULL, kSigmaXy},
                                       {"sigma-yaw", required_argument, NULL, kSigmaYaw},
                                       {"frame", required_argument, NULL, kFrame},
                                       {"stamp", required_argument, NULL, kStamp},
                                       {"wait-readers", required_argument, NULL, kWaitReaders},
                                       {"wait-timeout", required_argument, NULL, kWaitTimeout},
                                       {"repeat", required_argument, NULL, kRepeat},
                                       {"period", required_argument, NULL, kPeriod},
                                       {"help", no_argument, NULL, kHelp},
                                       {NULL, 0, NULL, 0}};
  long domain = -1, wait_readers = 1, repeat = 3;
  const char *topic = NULL, *frame = "map";
  double x = 0, y = 0, yaw = 0, sigma_xy = 0.5, sigma_yaw = 0.3, stamp = 0, wait_timeout = 30,
         period = 0.5;
  bool have_x = false, have_y = false, have_yaw = false;
  int c;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    switch (c) {
      case kDomain:
        domain = parse_long_arg(kCmd, "domain", optarg, 0, 232);
        break;
      case kTopic:
        topic = parse_string_arg(kCmd, "topic", optarg);
        break;
      case kX:
        x = parse_double_arg(kCmd, "x", optarg, -1e9, 1e9);
        have_x = true;
        break;
      case kY:
        y = parse_double_arg(kCmd, "y", optarg, -1e9, 1e9);
        have_y = true;
        break;
      case kYaw:
        yaw = parse_double_arg(kCmd, "yaw", optarg, -1e3, 1e3);
        have_yaw = true;
        break;
      case kSigmaXy:
        sigma_xy = parse_double_arg(kCmd, "sigma-xy", optarg, 0, 1e6);
        break;
      case kSigmaYaw:
        sigma_yaw = parse_double_arg(kCmd, "sigma-yaw", optarg, 0, 1e3);
        break;
      case kFrame:
        frame = parse_string_arg(kCmd, "frame", optarg);
        break;
      case kStamp:
        stamp = parse_double_arg(kCmd, "stamp", optarg, 0, 2147483647.0);
        break;
      case kWaitReaders:
        wait_readers = parse_long_arg(kCmd, "wait-readers", optarg, 0, 1000);
        break;
      case kWaitTimeout:
        wait_timeout = parse_double_arg(kCmd, "wait-timeout", optarg, 0, 1e7);
        break;
      case kRepeat:
        repeat = parse_long_arg(kCmd, "repeat", optarg, 1, 1000000);
        break;
      case kPeriod:
        period = parse_double_arg(kCmd, "period", optarg, 0, 1e5);
        break;
      case kHelp:
        initialpose_usage(stdout);
        return PEER_EXIT_OK;
      default:
        bad_option(kCmd, argv);
    }
  }
  reject_positional(kCmd, argc, argv, optind);
  require_arg(kCmd, "domain", domain >= 0);
  require_arg(kCmd, "topic", topic != NULL);
  require_arg(kCmd, "x", have_x);
  require_arg(kCmd, "y", have_y);
  require_arg(kCmd, "yaw", have_yaw);

  install_signal_handlers();
  const dds_entity_t participant = create_participant_or_exit(domain);
  const dds_entity_t writer = create_writer_or_exit(
      participant,
      create_topic_or_exit(participant, &geometry_msgs_msg_dds__PoseWithCovarianceStamped__desc,
                           topic),
      make_qos(true, false, 1));
  if (!wait_for_readers(writer, wait_readers, wait_timeout)) {
    fprintf(stderr, "esfleet-ros2-peer initialpose: %s: fewer than %ld readers matched in %g s\n",
            topic, wait_readers, wait_timeout);
    dds_delete(participant);
    return PEER_EXIT_FAIL;
  }
  geometry_msgs_msg_dds__PoseWithCovarianceStamped_ m;
  memset(&m, 0, sizeof m);
  m.header.stamp = stamp_from_seconds(stamp);
  m.header.frame_id = (char*)frame;
  m.pose.pose.position.x = x;
  m.pose.pose.position.y = y;
  m.pose.pose.position.z = 0.0;
  m.pose.pose.orientation = quaternion_of_yaw(yaw);
  m.pose.covariance[0] = sigma_xy * sigma_xy;
  m.pose.covariance[7] = sigma_xy * sigma_xy;
  m.pose.covariance[35] = sigma_yaw * sigma_yaw;
  long sent = 0;
  for (long k = 0; k < repeat && !peer_stop; ++k) {
    if (k > 0 && !sleep_seconds(period)) break;
    if (!write_sample(writer, &m, topic)) break;
    ++sent;
  }
  if (sent == repeat) dds_wait_for_acks(writer, DDS_SECS(5));
  printf("{\"initialpose_published\":%ld}\n", sent);
  fflush(stdout);
  dds_delete(participant);
  return sent == repeat ? PEER_EXIT_OK : PEER_EXIT_FAIL;
}
