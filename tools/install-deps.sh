#!/usr/bin/env bash
# Installs the Debian bookworm packages esfleet builds and runs with (only those missing).
# Needs root (or sudo) the first time; does nothing when everything is installed.
set -euo pipefail
packages=(
  build-essential cmake pkg-config python3
  libeigen3-dev libopencv-dev zlib1g-dev libpng-dev
  libcli11-dev libspdlog-dev libyaml-cpp-dev nlohmann-json3-dev
  libboost-dev  # esfleet-view: Boost.Beast and Boost.Asio (header-only)
  libgtest-dev libgmock-dev libbenchmark-dev
  libfastrtps-dev libfastcdr-dev fastddsgen fastdds-tools default-jre-headless
  iproute2 nftables  # deploy/netns/testbed.sh and its test (network namespaces, tc, loss)
  clang libclang-rt-14-dev  # fuzz/: clang 14 with libFuzzer and the ASan/UBSan runtimes
  openssl tcpdump  # deploy/security/make-fleet-certs.sh; the security capture test
  cyclonedds-dev cyclonedds-tools  # tests/ros2: Cyclone DDS, the independent ROS 2 DDS peer
  chromium  # tests/view: the browser test (playwright-core from npm drives it; needs node/npm)
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi
echo "installing: ${missing[*]}" >&2
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" apt-get update
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}"
