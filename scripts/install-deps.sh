#!/usr/bin/env bash
# The one list of what flatscan needs on a fresh Debian 12 machine. Every entry point
# (README commands, .ci/run) calls this script; nothing else installs packages.
set -euo pipefail
PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libopencv-dev libopencv-contrib-dev opencv-doc   # calib3d, imgproc, FileStorage; opencv-doc has the stereo sample images
  libeigen3-dev libnanoflann-dev libtbb-dev
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  zlib1g-dev                                        # CRC-32 of PNG chunks (io/image_io.cc)
  libssl-dev                                        # SHA-256 of files and images (util/sha256.cc: libcrypto)
  libsqlite3-dev libyaml-cpp-dev                    # the station's results store and recipe files (station/)
  libdeflate-dev                                    # inflating PNG image data (io/image_io.cc)
  libspng-dev                                       # a PNG decoder compared with ours and OpenCV's (bench/inspect_bench)
  libmodbus-dev                                     # Modbus TCP server for the PLC (outputs/modbus_server.cc)
  libmosquitto-dev mosquitto                        # MQTT line output (outputs/mqtt_publisher.cc); the broker for its tests
  libpq-dev postgresql                              # the plant store (store/postgres_results_store.cc); the server for its tests
  libaravis-dev libusb-1.0-0-dev aravis-tools       # GenICam cameras (acquisition/); aravis-0.8.pc needs libusb's .pc; the fake GigE camera
  iproute2 util-linux                               # `ip` and `unshare`: the two-GigE-camera tests in a private network namespace
  libcpp-httplib-dev                                # the station's web page (outputs/http_server.cc)
  chromium                                          # headless browser: the web page test, report --pdf, screenshots
  libcmark-gfm-dev libcmark-gfm-extensions-dev      # Markdown (with tables) to HTML: the evaluate study's report.html
  openssl                                           # self-signed certificates for the TLS tests (MQTT, PostgreSQL)
  libboost-math-dev                                 # Boost.Math: F and t distributions, the gauge studies' p-values (gauge/)
  libgtest-dev libgmock-dev libbenchmark-dev
  clang-14 libclang-rt-14-dev                       # scripts/fuzz.sh: libFuzzer (the corpora replay under ctest with g++)
)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "install-deps: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
