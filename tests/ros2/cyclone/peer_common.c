/* esfleet-ros2-peer: helpers shared by the subcommands. */
#define _POSIX_C_SOURCE 200809L
#include "peer_common.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

volatile sig_atomic_t peer_stop = 0;

static void on_signal(int sig) {
  (void)sig;
  peer_stop = 1;
}

void install_signal_handlers(void) {
  struct sigaction sa;
  memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = 0; /* no SA_RESTART: sleeps return early */
  sigaction(SIGINT, &sa, NULL);
  sigaction(SIGTERM, &sa, NULL);
}

/* ---- arguments ---- */

_Noreturn void usage_error(const char* cmd, const char* fmt, ...) {
  va_list ap;
  fprintf(stderr, "esfleet-ros2-peer %s: ", cmd);
  va_start(ap, fmt);
  vfprintf(stderr, fmt, ap);
  va_end(ap);
  fprintf(stderr, " (see esfleet-ros2-peer %s --help)\n", cmd);
  exit(PEER_EXIT_USAGE);
}

long parse_long_arg(const char* cmd, const char* name, const char* text, long min, long max) {
  if (text == NULL || *text == '\0') usage_error(cmd, "--%s: empty value", name);
  errno = 0;
  char* end = NULL;
  const long v = strtol(text, &end, 10);
  if (errno != 0 || end == text || *end != '\0') {
    usage_error(cmd, "--%s: not an integer: '%s'", name, text);
  }
  if (v < min || v > max) {
    usage_error(cmd, "--%s: %ld is outside [%ld, %ld]", name, v, min, max);
  }
  return v;
}

double parse_double_arg(const char* cmd, const char* name, const char* text, double min,
                        double max) {
  if (text == NULL || *text == '\0') usage_error(cmd, "--%s: empty value", name);
  errno = 0;
  char* end = NULL;
  const double v = strtod(text, &end);
  if (end == text || *end != '\0' || errno == ERANGE) {
    usage_error(cmd, "--%s: not a number: '%s'", name, text);
  }
  if (!isfinite(v)) usage_error(cmd, "--%s: not finite: '%s'", name, text);
  if (v < min || v > max) usage_error(cmd, "--%s: %g is outside [%g, %g]", name, v, min, max);
  return v;
}

const char* parse_string_arg(const char* cmd, const char* name, const char* text) {
  if (text == NULL || *text == '\0') usage_error(cmd, "--%s: empty value", name);
  return text;
}

void require_arg(const char* cmd, const char* name, bool given) {
  if (!given) usage_error(cmd, "--%s is required", name);
}

void reject_positional(const char* cmd, int argc, char** argv, int optind) {
  if (optind < argc) usage_error(cmd, "unexpected argument '%s'", argv[optind]);
}

/* ---- time ---- */

double monotonic_seconds(void) {
  struct timespec ts;
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

bool sleep_seconds(double s) {
  const double until = monotonic_seconds() + s;
  while (!peer_stop) {
    const double left = until - monotonic_seconds();
    if (left <= 0) return true;
    const double step = left < 0.05 ? left : 0.05;
    struct timespec ts;
    ts.tv_sec = (time_t)step;
    ts.tv_nsec = (long)((step - (double)ts.tv_sec) * 1e9);
    nanosleep(&ts, NULL);
  }
  return false;
}

builtin_interfaces_msg_dds__Time_ stamp_from_seconds(double t) {
  builtin_interfaces_msg_dds__Time_ out = {0, 0};
  if (!isfinite(t)) return out;
  double whole = floor(t);
  long long ns = llround((t - whole) * 1e9);
  if (ns >= 1000000000LL) {
    whole += 1.0;
    ns -= 1000000000LL;
  }
  if (whole < (double)INT32_MIN) whole = (double)INT32_MIN;
  if (whole > (double)INT32_MAX) whole = (double)INT32_MAX;
  out.sec = (int32_t)whole;
  out.nanosec = (uint32_t)ns;
  return out;
}

double stamp_seconds(const builtin_interfaces_msg_dds__Time_* t) {
  return (double)t->sec + (double)t->nanosec * 1e-9;
}

int64_t stamp_nanoseconds(const builtin_interfaces_msg_dds__Time_* t) {
  return (int64_t)t->sec * 1000000000LL + (int64_t)t->nanosec;
}

double yaw_of_quaternion(const geometry_msgs_msg_dds__Quaternion_* q) {
  return atan2(2.0 * (q->w * q->z + q->x * q->y), 1.0 - 2.0 * (q->y * q->y + q->z * q->z));
}

geometry_msgs_msg_dds__Quaternion_ quaternion_of_yaw(double yaw) {
  geometry_msgs_msg_dds__Quaternion_ q = {0.0, 0.0, sin(yaw / 2.0), cos(yaw / 2.0)};
  return q;
}

/* ---- DDS ---- */

dds_entity_t create_participant_or_exit(long domain) {
  const dds_entity_t p = dds_create_participant((dds_domainid_t)domain, NULL, NULL);
  if (p < 0) {
    fprintf(stderr, "esfleet-ros2-peer: dds_create_participant(domain %ld): %s\n", domain,
            dds_strretcode(p));
    exit(PEER_EXIT_FAIL);
  }
  return p;
}

dds_entity_t create_topic_or_exit(dds_entity_t participant, const dds_topic_descriptor_t* desc,
                                  const char* name) {
  const dds_entity_t t = dds_create_topic(participant, desc, name, NULL, NULL);
  if (t < 0) {
    fprintf(stderr, "esfleet-ros2-peer: dds_create_topic(%s, %s): %s\n", name, desc->m_typename,
            dds_strretcode(t));
    exit(PEER_EXIT_FAIL);
  }
  return t;
}

dds_qos_t* make_qos(bool reliable, bool transient_local, int32_t depth) {
  dds_qos_t* q = dds_create_qos();
  if (reliable) {
    dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(10));
  } else {
    dds_qset_reliability(q, DDS_RELIABILITY_BEST_EFFORT, 0);
  }
  dds_qset_durability(q,
                      transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(q, DDS_HISTORY_KEEP_LAST, depth);
  const dds_data_representation_id_t xcdr1[1] = {DDS_DATA_REPRESENTATION_XCDR1};
  dds_qset_data_representation(q, 1, xcdr1);
  return q;
}

static void entity_failure(const char* what, dds_entity_t topic, dds_return_t rc) {
  char name[256] = "?";
  dds_get_name(topic, name, sizeof name);
  fprintf(stderr, "esfleet-ros2-peer: %s on %s: %s\n", what, name, dds_strretcode(rc));
  exit(PEER_EXIT_FAIL);
}

dds_entity_t create_reader_or_exit(dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos) {
  const dds_entity_t r = dds_create_reader(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (r < 0) entity_failure("dds_create_reader", topic, r);
  return r;
}

dds_entity_t create_writer_or_exit(dds_entity_t participant, dds_entity_t topic, dds_qos_t* qos) {
  const dds_entity_t w = dds_create_writer(participant, topic, qos, NULL);
  dds_delete_qos(qos);
  if (w < 0) entity_failure("dds_create_writer", topic, w);
  return w;
}

bool wait_for_readers(dds_entity_t writer, long n, double timeout_s) {
  if (n <= 0) return true;
  const double until = monotonic_seconds() + timeout_s;
  while (!peer_stop) {
    dds_publication_matched_status_t st;
    if (dds_get_publication_matched_status(writer, &st) == DDS_RETCODE_OK &&
        (long)st.current_count >= n) {
      return true;
    }
    if (monotonic_seconds() >= until) return false;
    sleep_seconds(0.02);
  }
  return false;
}

bool write_sample(dds_entity_t writer, const void* sample, const char* what) {
  const dds_return_t rc = dds_write(writer, sample);
  if (rc != DDS_RETCODE_OK) {
    fprintf(stderr, "esfleet-ros2-peer: dds_write(%s): %s\n", what, dds_strretcode(rc));
    return false;
  }
  return true;
}

/* ---- JSON ---- */

void json_string(FILE* f, const char* s) {
  fputc('"', f);
  for (const unsigned char* p = (const unsigned char*)(s ? s : ""); *p; ++p) {
    switch (*p) {
      case '"':
        fputs("\\\"", f);
        break;
      case '\\':
        fputs("\\\\", f);
        break;
      case '\n':
        fputs("\\n", f);
        break;
      case '\r':
        fputs("\\r", f);
        break;
      case '\t':
        fputs("\\t", f);
        break;
      default:
        /* control characters and non-ASCII bytes as \u00XX: always valid JSON */
        if (*p < 0x20 || *p >= 0x7f) {
          fprintf(f, "\\u%04x", (unsigned)*p);
        } else {
          fputc(*p, f);
        }
    }
  }
  fputc('"', f);
}

void json_stamp(FILE* f, const builtin_interfaces_msg_dds__Time_* t) {
  if (t->sec >= 0 && t->nanosec < 1000000000u) {
    fprintf(f, "%d.%09u", (int)t->sec, (unsigned)t->nanosec);
  } else {
    json_double(f, stamp_seconds(t));
  }
}

void json_double(FILE* f, double v) {
  if (!isfinite(v)) {
    fputs("null", f);
    return;
  }
  char buf[64];
  for (int prec = 15; prec <= 17; ++prec) {
    snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (strtod(buf, NULL) == v) break;
  }
  fputs(buf, f);
}

void json_float(FILE* f, float v) {
  if (!isfinite(v)) {
    fputs("null", f);
    return;
  }
  char buf[64];
  for (int prec = 6; prec <= 9; ++prec) {
    snprintf(buf, sizeof buf, "%.*g", prec, (double)v);
    if (strtof(buf, NULL) == v) break;
  }
  fputs(buf, f);
}
