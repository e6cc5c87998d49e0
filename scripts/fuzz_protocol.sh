#!/usr/bin/env bash
# Builds the protocol parser fuzzer with clang (libFuzzer + ASan + UBSan) and runs it.
#   scripts/fuzz_protocol.sh [SECONDS]    (default 60; crashes land in build-fuzz/)
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p build-fuzz/corpus
clang++ -std=c++20 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined -I. \
  tests/fuzz/fuzz_protocol.cpp server/protocol.cpp core/error.cpp -o build-fuzz/fuzz_protocol
cp -n tests/fuzz/protocol_corpus/* build-fuzz/corpus/ 2>/dev/null || true
build-fuzz/fuzz_protocol -max_total_time="${1:-60}" -max_len=4096 -artifact_prefix=build-fuzz/ \
  -dict=tests/fuzz/protocol.dict build-fuzz/corpus
