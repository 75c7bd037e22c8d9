/* esfleet-ros2-peer map-reader: rt/map + rt/map_updates -> the applied grid and the last map. */
#define _POSIX_C_SOURCE 200809L
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "peer_common.h"
#include "subcommands.h"

static const char* const kCmd = "map-reader";

void map_reader_usage(FILE* f) {
  fprintf(f,
          "usage: esfleet-ros2-peer map-reader --domain D --out PREFIX [--timeout S] "
          "[--idle-exit S] [--until-maps N]\n"
          "  Subscribes rt/map (nav_msgs/OccupancyGrid; reliable, transient-local, keep-last 1)\n"
          "  and rt/map_updates (map_msgs/OccupancyGridUpdate; reliable, volatile, keep-last 64).\n"
          "  G = the first /map; a later /map replaces G only if width, height, resolution or\n"
          "  origin differ (a geometry change). Updates inside G with a stamp >= G's base map's\n"
          "  stamp are applied (updates before the first map are buffered); others are counted.\n"
          "  --domain D       DDS domain id (0..232)\n"
          "  --out PREFIX     writes PREFIX.applied.{json,bin} (G) and PREFIX.last.{json,bin}\n"
          "                   (the last /map received); .bin = width*height int8, row-major\n"
          "  --timeout S      exit after S seconds (default 60; 0 = none)\n"
          "  --idle-exit S    exit after S seconds without a message once a map arrived "
          "(default 0 = off)\n"
          "  --until-maps N   exit once N maps arrived (default 0 = off)\n"
          "  Exits on SIGINT/SIGTERM too. Exit code 0 if a map arrived, 1 if not, 2 on bad "
          "arguments.\n"
          "  Prints one JSON summary line on stdout.\n");
}

/* A full map as received. */
typedef struct {
  uint32_t width, height;
  float resolution;
  geometry_msgs_msg_dds__Pose_ origin;
  char* frame_id;
  builtin_interfaces_msg_dds__Time_ stamp;
  int8_t* data; /* width*height */
} grid_t;

typedef struct {
  builtin_interfaces_msg_dds__Time_ stamp;
  int32_t x, y;
  uint32_t width, height;
  int8_t* data;
  uint32_t length;
} update_t;

typedef struct {
  bool have_map;
  grid_t applied; /* G */
  grid_t last;    /* L */
  long maps_received, updates_received, updates_applied, updates_outside, updates_stale,
      updates_malformed, updates_dropped, geometry_changes;
  double first_map_after_s;
  bool have_update_stamp;
  builtin_interfaces_msg_dds__Time_ last_update_stamp; /* newest applied update */
  update_t* pending;
  size_t n_pending, cap_pending;
} state_t;

enum { kMaxPending = 4096 };

static void grid_free(grid_t* g) {
  free(g->frame_id);
  free(g->data);
  memset(g, 0, sizeof *g);
}

static char* dup_string(const char* s) {
  const char* src = s ? s : "";
  const size_t n = strlen(src);
  char* out = malloc(n + 1);
  if (out == NULL) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: out of memory\n");
    exit(PEER_EXIT_FAIL);
  }
  memcpy(out, src, n + 1);
  return out;
}

static void* checked_malloc(size_t n) {
  void* p = malloc(n ? n : 1);
  if (p == NULL) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: out of memory (%zu bytes)\n", n);
    exit(PEER_EXIT_FAIL);
  }
  return p;
}

/* Copies a received map; false (and a message) if its data length is not width*height. */
static bool grid_from_msg(grid_t* g, const nav_msgs_msg_dds__OccupancyGrid_* m) {
  const uint64_t cells = (uint64_t)m->info.width * (uint64_t)m->info.height;
  if ((uint64_t)m->data._length != cells || (cells > 0 && m->data._buffer == NULL)) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: /map ignored: %u x %u cells but %u data bytes\n",
            m->info.width, m->info.height, m->data._length);
    return false;
  }
  g->width = m->info.width;
  g->height = m->info.height;
  g->resolution = m->info.resolution;
  g->origin = m->info.origin;
  g->frame_id = dup_string(m->header.frame_id);
  g->stamp = m->header.stamp;
  g->data = checked_malloc((size_t)cells);
  if (cells > 0) memcpy(g->data, m->data._buffer, (size_t)cells);
  return true;
}

static bool grid_copy(grid_t* dst, const grid_t* src) {
  *dst = *src;
  dst->frame_id = dup_string(src->frame_id);
  const size_t cells = (size_t)src->width * src->height;
  dst->data = checked_malloc(cells);
  if (cells > 0) memcpy(dst->data, src->data, cells);
  return true;
}

static bool same_double(double a, double b) { return a == b || (isnan(a) && isnan(b)); }

static bool same_geometry(const grid_t* a, const grid_t* b) {
  const geometry_msgs_msg_dds__Pose_ *p = &a->origin, *q = &b->origin;
  return a->width == b->width && a->height == b->height &&
         (a->resolution == b->resolution || (isnan(a->resolution) && isnan(b->resolution))) &&
         same_double(p->position.x, q->position.x) && same_double(p->position.y, q->position.y) &&
         same_double(p->position.z, q->position.z) &&
         same_double(p->orientation.x, q->orientation.x) &&
         same_double(p->orientation.y, q->orientation.y) &&
         same_double(p->orientation.z, q->orientation.z) &&
         same_double(p->orientation.w, q->orientation.w);
}

/* Applies (or counts) one update against G. */
static void apply_update(state_t* s, const update_t* u) {
  grid_t* g = &s->applied;
  const int64_t x = u->x, y = u->y, w = u->width, h = u->height;
  if ((uint64_t)u->length != (uint64_t)w * (uint64_t)h) {
    ++s->updates_malformed;
    return;
  }
  if (x < 0 || y < 0 || x + w > (int64_t)g->width || y + h > (int64_t)g->height) {
    ++s->updates_outside;
    return;
  }
  if (stamp_nanoseconds(&u->stamp) < stamp_nanoseconds(&g->stamp)) {
    ++s->updates_stale;
    return;
  }
  for (int64_t row = 0; row < h; ++row) {
    memcpy(g->data + (size_t)((y + row) * (int64_t)g->width + x), u->data + (size_t)(row * w),
           (size_t)w);
  }
  ++s->updates_applied;
  if (!s->have_update_stamp ||
      stamp_nanoseconds(&u->stamp) > stamp_nanoseconds(&s->last_update_stamp)) {
    s->last_update_stamp = u->stamp;
    s->have_update_stamp = true;
  }
}

static void on_map(state_t* s, const nav_msgs_msg_dds__OccupancyGrid_* m, double t0) {
  grid_t incoming;
  memset(&incoming, 0, sizeof incoming);
  if (!grid_from_msg(&incoming, m)) return;
  ++s->maps_received;
  if (!s->have_map) {
    s->have_map = true;
    s->first_map_after_s = monotonic_seconds() - t0;
    grid_copy(&s->applied, &incoming);
    s->last = incoming;
    for (size_t i = 0; i < s->n_pending; ++i) {
      apply_update(s, &s->pending[i]);
      free(s->pending[i].data);
    }
    s->n_pending = 0;
    return;
  }
  if (!same_geometry(&s->applied, &incoming)) {
    ++s->geometry_changes;
    grid_free(&s->applied);
    grid_copy(&s->applied, &incoming);
  }
  grid_free(&s->last);
  s->last = incoming;
}

static void on_update(state_t* s, const map_msgs_msg_dds__OccupancyGridUpdate_* m) {
  ++s->updates_received;
  update_t u;
  u.stamp = m->header.stamp;
  u.x = m->x;
  u.y = m->y;
  u.width = m->width;
  u.height = m->height;
  u.length = m->data._length;
  if (u.length > 0 && m->data._buffer == NULL) {
    ++s->updates_malformed;
    return;
  }
  if (s->have_map) {
    u.data = m->data._buffer; /* borrowed: applied at once */
    apply_update(s, &u);
    return;
  }
  if (s->n_pending >= kMaxPending) {
    ++s->updates_dropped;
    return;
  }
  if (s->n_pending == s->cap_pending) {
    const size_t cap = s->cap_pending ? 2 * s->cap_pending : 64;
    update_t* p = realloc(s->pending, cap * sizeof *p);
    if (p == NULL) {
      ++s->updates_dropped;
      return;
    }
    s->pending = p;
    s->cap_pending = cap;
  }
  u.data = checked_malloc(u.length);
  if (u.length > 0) memcpy(u.data, m->data._buffer, u.length);
  s->pending[s->n_pending++] = u;
}

/* ---- output ---- */

static bool write_bytes_atomically(const char* path, const void* data, size_t n) {
  const size_t len = strlen(path) + 5;
  char* tmp = checked_malloc(len);
  snprintf(tmp, len, "%s.tmp", path);
  FILE* f = fopen(tmp, "wb");
  bool ok = f != NULL;
  if (ok && n > 0) ok = fwrite(data, 1, n, f) == n;
  if (f != NULL && fclose(f) != 0) ok = false;
  if (ok && rename(tmp, path) != 0) ok = false;
  if (!ok) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: cannot write %s\n", path);
    remove(tmp);
  }
  free(tmp);
  return ok;
}

static char* path_with(const char* prefix, const char* suffix) {
  const size_t len = strlen(prefix) + strlen(suffix) + 1;
  char* p = checked_malloc(len);
  snprintf(p, len, "%s%s", prefix, suffix);
  return p;
}

/* {"width",...} for grid g plus the counters. */
static bool write_grid(const state_t* s, const grid_t* g, const char* prefix, const char* which,
                       bool applied) {
  char* bin = path_with(prefix, which);
  char* bin_path = path_with(bin, ".bin");
  char* json_path = path_with(bin, ".json");
  bool ok = write_bytes_atomically(bin_path, g->data, (size_t)g->width * g->height);

  char* buf = NULL;
  size_t size = 0;
  FILE* f = open_memstream(&buf, &size);
  if (f == NULL) {
    ok = false;
  } else {
    fprintf(f, "{\"width\":%u,\"height\":%u,\"resolution\":", g->width, g->height);
    json_float(f, g->resolution);
    fputs(",\"origin_x\":", f);
    json_double(f, g->origin.position.x);
    fputs(",\"origin_y\":", f);
    json_double(f, g->origin.position.y);
    fputs(",\"origin_yaw\":", f);
    json_double(f, yaw_of_quaternion(&g->origin.orientation));
    fputs(",\"frame_id\":", f);
    json_string(f, g->frame_id);
    fputs(",\"stamp\":", f);
    json_stamp(f, &g->stamp);
    fprintf(f,
            ",\"maps_received\":%ld,\"updates_received\":%ld,\"updates_applied\":%ld,"
            "\"updates_outside\":%ld,\"updates_stale\":%ld,\"updates_malformed\":%ld,"
            "\"updates_dropped\":%ld,\"geometry_changes\":%ld,\"first_map_after_s\":",
            s->maps_received, s->updates_received, s->updates_applied, s->updates_outside,
            s->updates_stale, s->updates_malformed, s->updates_dropped, s->geometry_changes);
    json_double(f, s->first_map_after_s);
    if (applied) {
      fputs(",\"last_update_stamp\":", f);
      if (s->have_update_stamp) {
        json_stamp(f, &s->last_update_stamp);
      } else {
        fputs("null", f);
      }
    }
    fputs("}\n", f);
    if (fclose(f) != 0) ok = false;
    if (ok) ok = write_bytes_atomically(json_path, buf, size);
    free(buf);
  }
  free(bin);
  free(bin_path);
  free(json_path);
  return ok;
}

/* ---- main loop ---- */

typedef struct {
  bool is_map;
  dds_time_t source_timestamp;
  const void* sample;
} received_t;

static int by_source_time(const void* a, const void* b) {
  const received_t *x = a, *y = b;
  if (x->source_timestamp != y->source_timestamp) {
    return x->source_timestamp < y->source_timestamp ? -1 : 1;
  }
  /* same instant: the map first, so updates stamped with it apply to it */
  return (int)y->is_map - (int)x->is_map;
}

enum { kBatch = 64 };

/* Takes what both readers hold and processes it in source-timestamp order (esfleet writes both
 * topics from one process, so that is its publication order). Returns the number taken. */
static int take_and_process(state_t* s, dds_entity_t map_reader, dds_entity_t update_reader,
                            double t0) {
  void* maps[kBatch] = {NULL};
  void* updates[kBatch] = {NULL};
  dds_sample_info_t map_info[kBatch], update_info[kBatch];
  int n_maps = dds_take(map_reader, maps, map_info, kBatch, kBatch);
  int n_updates = dds_take(update_reader, updates, update_info, kBatch, kBatch);
  if (n_maps < 0) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: dds_take(rt/map): %s\n", dds_strretcode(n_maps));
    n_maps = 0;
  }
  if (n_updates < 0) {
    fprintf(stderr, "esfleet-ros2-peer map-reader: dds_take(rt/map_updates): %s\n",
            dds_strretcode(n_updates));
    n_updates = 0;
  }
  received_t order[2 * kBatch];
  int n = 0;
  for (int i = 0; i < n_maps; ++i) {
    if (map_info[i].valid_data) {
      order[n++] = (received_t){true, map_info[i].source_timestamp, maps[i]};
    }
  }
  for (int i = 0; i < n_updates; ++i) {
    if (update_info[i].valid_data) {
      order[n++] = (received_t){false, update_info[i].source_timestamp, updates[i]};
    }
  }
  qsort(order, (size_t)n, sizeof order[0], by_source_time);
  for (int i = 0; i < n; ++i) {
    if (order[i].is_map) {
      on_map(s, order[i].sample, t0);
    } else {
      on_update(s, order[i].sample);
    }
  }
  if (n_maps > 0) dds_return_loan(map_reader, maps, n_maps);
  if (n_updates > 0) dds_return_loan(update_reader, updates, n_updates);
  return n;
}

int map_reader_main(int argc, char** argv) {
  static const struct option opts[] = {{"domain", required_argument, NULL, 'd'},
                                       {"out", required_argument, NULL, 'o'},
                                       {"timeout", required_argument, NULL, 't'},
                                       {"idle-exit", required_argument, NULL, 'i'},
                                       {"until-maps", required_argument, NULL, 'n'},
                                       {"help", no_argument, NULL, 'h'},
                                       {NULL, 0, NULL, 0}};
  long domain = -1, until_maps = 0;
  const char* prefix = NULL;
  double timeout = 60, idle_exit = 0;
  int c;
  opterr = 0;
  while ((c = getopt_long(argc, argv, "", opts, NULL)) != -1) {
    switch (c) {
      case 'd':
        domain = parse_long_arg(kCmd, "domain", optarg, 0, 232);
        break;
      case 'o':
        prefix = parse_string_arg(kCmd, "out", optarg);
        break;
      case 't':
        timeout = parse_double_arg(kCmd, "timeout", optarg, 0, 1e7);
        break;
      case 'i':
        idle_exit = parse_double_arg(kCmd, "idle-exit", optarg, 0, 1e7);
        break;
      case 'n':
        until_maps = parse_long_arg(kCmd, "until-maps", optarg, 0, 1000000000L);
        break;
      case 'h':
        map_reader_usage(stdout);
        return PEER_EXIT_OK;
      default:
        bad_option(kCmd, argv);
    }
  }
  reject_positional(kCmd, argc, argv, optind);
  require_arg(kCmd, "domain", domain >= 0);
  require_arg(kCmd, "out", prefix != NULL);

  install_signal_handlers();
  const double t0 = monotonic_seconds();
  const dds_entity_t participant = create_participant_or_exit(domain);
  const dds_entity_t map_topic =
      create_topic_or_exit(participant, &nav_msgs_msg_dds__OccupancyGrid__desc, "rt/map");
  const dds_entity_t update_topic = create_topic_or_exit(
      participant, &map_msgs_msg_dds__OccupancyGridUpdate__desc, "rt/map_updates");
  const dds_entity_t map_reader =
      create_reader_or_exit(participant, map_topic, make_qos(true, true, 1));
  const dds_entity_t update_reader =
      create_reader_or_exit(participant, update_topic, make_qos(true, false, 64));

  const dds_entity_t waitset = dds_create_waitset(participant);
  const dds_entity_t map_cond = dds_create_readcondition(map_reader, DDS_ANY_STATE);
  const dds_entity_t update_cond = dds_create_readcondition(update_reader, DDS_ANY_STATE);
  dds_waitset_attach(waitset, map_cond, 0);
  dds_waitset_attach(waitset, update_cond, 0);

  state_t s;
  memset(&s, 0, sizeof s);
  double last_message = monotonic_seconds();
  const char* reason = "signal";
  for (;;) {
    if (peer_stop) break;
    const double now = monotonic_seconds();
    if (timeout > 0 && now - t0 >= timeout) {
      reason = "timeout";
      break;
    }
    if (s.have_map && idle_exit > 0 && now - last_message >= idle_exit) {
      reason = "idle";
      break;
    }
    if (until_maps > 0 && s.maps_received >= until_maps) {
      reason = "until-maps";
      break;
    }
    dds_waitset_wait(waitset, NULL, 0, DDS_MSECS(100));
    /* one batch per round, so the exit conditions are checked under a steady stream too */
    if (take_and_process(&s, map_reader, update_reader, t0) > 0) last_message = monotonic_seconds();
  }

  bool ok = true;
  if (s.have_map) {
    ok = write_grid(&s, &s.applied, prefix, ".applied", true) &&
         write_grid(&s, &s.last, prefix, ".last", false);
  } else {
    fprintf(stderr, "esfleet-ros2-peer map-reader: no /map received (%s)\n", reason);
  }
  printf(
      "{\"exit\":\"%s\",\"maps_received\":%ld,\"updates_received\":%ld,"
      "\"updates_applied\":%ld,\"updates_outside\":%ld,\"updates_stale\":%ld,"
      "\"updates_malformed\":%ld,\"geometry_changes\":%ld}\n",
      reason, s.maps_received, s.updates_received, s.updates_applied, s.updates_outside,
      s.updates_stale, s.updates_malformed, s.geometry_changes);
  fflush(stdout);

  for (size_t i = 0; i < s.n_pending; ++i) free(s.pending[i].data);
  free(s.pending);
  grid_free(&s.applied);
  grid_free(&s.last);
  dds_delete(participant);
  if (!s.have_map || !ok) return PEER_EXIT_FAIL;
  return PEER_EXIT_OK;
}
