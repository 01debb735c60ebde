#!/usr/bin/env bash
# Installs Strata's build dependencies from Debian bookworm (apt only). Idempotent: when every
# package is already installed it returns in well under a second without touching the network.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  protobuf-compiler libprotobuf-dev protobuf-compiler-grpc libgrpc++-dev grpc-proto
  golang-github-gogo-googleapis-dev
  libeigen3-dev libpcl-dev liboctomap-dev liblbfgspp-dev prometheus-cpp-dev libxxhash-dev
  libmicrohttpd-dev  # the web viewer's HTTP server (server/http/http_server.cpp)
  libgtest-dev libgmock-dev libbenchmark-dev nlohmann-json3-dev
  libompl-dev
  libcli11-dev  # command-line parsing of the programs (header-only)
  libfmt-dev  # messages: fmt::format (CMakeLists.txt find_package(fmt 9))
  etcd-server  # tests/server: the shared schedule's tests run a real etcd (--etcd)
  python3-yaml  # tests/deploy: manifest checks with Debian's /usr/bin/python3
  openssl  # TLS tests make a throwaway certificate
  clang-format clang-tidy  # scripts/check-format.sh, check-tidy.sh (CI): .clang-format, .clang-tidy
  clang libclang-rt-14-dev libomp-dev  # the sanitised build (clang, its OpenMP) and libFuzzer
  lld  # links the sanitised and ThreadSanitizer builds (CMakeLists.txt)
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
# tests/deploy renders the Kubernetes manifests with `kubectl kustomize`: any kubectl on PATH
# will do, else Debian's kubernetes-client (kubectl 1.20, with kustomize built in).
command -v kubectl >/dev/null 2>&1 || missing+=(kubernetes-client)
if [ ${#missing[@]} -eq 0 ]; then
  exit 0
fi

echo "install-deps: installing ${missing[*]}" >&2
sudo_cmd=()
[ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
"${sudo_cmd[@]}" apt-get update
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y --no-install-recommends "${missing[@]}"
