#pragma once
// What the fleet launcher (esfleet-fleet) knows about each follower, from the pose topic (what
// the robot believes) and the simulator's truth topic (where it is). Evaluation only: nothing
// here feeds back into SLAM or localisation. Plain data in, plain data out, so it is unit-tested
// without DDS.

#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace esfleet::fleet {

/// A pose a robot published (msg::RobotPose, status as kStatus* in idl/esfleet.idl).
struct PoseSample {
  std::string robot_id;
  double stamp = 0.0;
  double x = 0.0, y = 0.0, theta = 0.0;
  std::uint8_t status = 0;
};

/// The simulator's true pose of a robot at the stamp of one of its scans (msg::TruthPose).
struct TruthSample {
  std::string robot_id;
  double stamp = 0.0;
  double x = 0.0, y = 0.0, theta = 0.0;
};

/// A declared pose counts as right when it lies within these of the truth.
struct Tolerance {
  double xy_m = 0.3;
  double theta_rad = 0.0872664626;  // 5 degrees
};

/// Status values of msg::RobotPose (kept equal to idl/esfleet.idl by static_asserts in
/// fleet_app.cpp, which sees both), so that the launcher's pure parts need no DDS headers.
inline constexpr std::uint8_t kStatusMapping = 0;
inline constexpr std::uint8_t kStatusWaitingForMap = 1;
inline constexpr std::uint8_t kStatusLocalising = 2;
inline constexpr std::uint8_t kStatusTracking = 3;
inline constexpr std::uint8_t kStatusLost = 4;
/// No pose received yet.
inline constexpr std::uint8_t kStatusNone = 255;

/// One follower as seen from outside.
struct RobotReport {
  std::string id;
  std::uint8_t status = kStatusNone;
  std::size_t poses = 0;                   ///< pose samples received
  std::size_t tracking_poses = 0;          ///< ... with status tracking
  std::size_t matched = 0;                 ///< tracking poses matched with a truth sample
  std::size_t declarations = 0;            ///< changes into tracking
  std::size_t wrong_declarations = 0;      ///< declared poses outside the tolerance
  std::size_t lost_events = 0;             ///< changes into lost
  std::optional<double> first_pose_s;      ///< launcher time of the first pose sample
  std::optional<double> localised_s;       ///< launcher time of the first tracking pose
  std::optional<double> first_error_xy_m;  ///< error of the first declared pose
  std::optional<double> first_error_theta_rad;
  std::vector<double> error_xy_m;  ///< per matched tracking pose
  std::vector<double> error_theta_rad;
  std::optional<double> last_error_xy_m;
  /// Since start_window(): scans the simulator sent (truth samples) and tracking poses the
  /// robot published. Equal counts = every scan processed.
  std::size_t window_truth = 0;
  std::size_t window_tracking_poses = 0;
};

/// Matches each robot's tracking poses with the truth of the same scan (same stamp) and keeps
/// the errors. Truth and poses may arrive in either order; each side keeps a bounded buffer.
class FleetMonitor {
 public:
  explicit FleetMonitor(Tolerance tolerance = {}) : tolerance_(tolerance) {}
  /// Registers a follower; samples of unregistered ids (the leader, strangers) are ignored.
  void add_robot(const std::string& id);
  void on_truth(const TruthSample& t);
  /// `now_s`: launcher time the sample was taken from the queue.
  void on_pose(const PoseSample& p, double now_s);
  const std::map<std::string, RobotReport>& robots() const { return robots_; }
  /// True when every registered robot's last pose had status tracking.
  bool all_tracking() const;
  /// Starts counting window_truth and window_tracking_poses (from zero).
  void start_window();
  bool window_started() const { return window_; }
  /// Samples of ids that were not registered.
  std::uint64_t ignored() const { return ignored_; }

  /// Buffer bounds: truth samples kept per robot, tracking poses waiting for their truth.
  static constexpr std::size_t kTruthKept = 600;
  static constexpr std::size_t kPendingKept = 100;

 private:
  struct Pending {
    PoseSample pose;
    bool declaration = false;
  };
  struct Buffers {
    std::deque<TruthSample> truth;
    std::deque<Pending> pending;
  };
  void score(RobotReport& r, const Pending& p, const TruthSample& t);

  Tolerance tolerance_;
  std::map<std::string, RobotReport> robots_;
  std::map<std::string, Buffers> buffers_;
  std::uint64_t ignored_ = 0;
  bool window_ = false;
};

/// Angle difference a - b wrapped to (-pi, pi].
double angle_diff(double a, double b);

/// utime + stime in clock ticks from the text of /proc/<pid>/stat; std::nullopt if malformed.
/// (The command name in parentheses may contain spaces and parentheses: fields are counted
/// after the last ')'.)
std::optional<std::uint64_t> parse_proc_stat_ticks(const std::string& stat);
/// VmRSS in kB from the text of /proc/<pid>/status; std::nullopt if absent.
std::optional<std::uint64_t> parse_proc_status_rss_kb(const std::string& status);

}  // namespace esfleet::fleet
