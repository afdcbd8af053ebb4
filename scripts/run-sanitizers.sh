#!/usr/bin/env bash
# The sanitizer job: an AddressSanitizer + UndefinedBehaviorSanitizer build of tests in its own build folder,
# then those tests under the sanitizers (the first report stops the test: -fno-sanitize-recover=all).
# Details, measured times and what is left out: doc/reliability-config.md ("Sanitizer job").
#
#   bash scripts/run-sanitizers.sh          # CI scope: the libraries that read files (core, datasets, eval, places, map)
#                                           # with all their unit tests and the rawlog / map fuzz tests
#   bash scripts/run-sanitizers.sh --all    # every unit and e2e test (the whole pipeline; ~25 min on 2 cores)
#   bash scripts/run-sanitizers.sh --thread # ThreadSanitizer build of the e2e tests, running the threaded-mode
#                                           # tests (tracking and local mapping in two threads), the
#                                           # local-mapping unit tests (its computations outside the map lock)
#                                           # the prefetching rawlog reader's tests, the ORB
#                                           # extractor's level threads and the map's gzip writer
# Files are compiled one by one (PRIORSLAM_UNITY_BUILD=OFF): this build also checks that each compiles alone.
# Env: SANITIZE_BUILD_DIR (default build-sanitize), SANITIZE_JOBS (default 2); ccache is used when installed.
# Called by .ci/run after scripts/run-tests.sh, which has installed the dependencies.
set -euo pipefail
cd "$(dirname "$0")/.."
SCOPE=ci
case "${1:-}" in
  "") ;;
  --all) SCOPE=all ;;
  --thread) SCOPE=thread ;;
  -h|--help) sed -n 2,14p "$0"; exit 0 ;;
  *) echo "run-sanitizers: unknown argument '$1' (see --help)" >&2; exit 2 ;;
esac
BUILD_DIR=${SANITIZE_BUILD_DIR:-build-sanitize}
JOBS=${SANITIZE_JOBS:-${JOBS:-2}}
launcher=()
if command -v ccache >/dev/null 2>&1; then launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache); fi

if [[ $SCOPE == thread ]]; then
  # TSan cannot share a build with ASan. -O1 as below. Ceres runs single-threaded in every config
  # ([BundleAdjustment] numThreads = 1); OpenCV's and OpenMP's thread pools are switched off below, so the only
  # threads are ours: tracking, the mapping thread and a loop's global BA (the H/F initializer's two std::async
  # tasks as well).
  BUILD_DIR=${SANITIZE_BUILD_DIR:-build-tsan}
  FLAGS="-fsanitize=thread -fno-omit-frame-pointer -O1 -g1"
  start=$(date +%s)
  cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Tsan -DCMAKE_CXX_FLAGS_TSAN="$FLAGS" \
    -DCMAKE_EXE_LINKER_FLAGS_TSAN=-fsanitize=thread -DCMAKE_SHARED_LINKER_FLAGS_TSAN=-fsanitize=thread \
    -DPRIORSLAM_BUILD_BENCHMARKS=OFF -DPRIORSLAM_UNITY_BUILD=OFF -DPRIORSLAM_PYTHON=OFF "${launcher[@]}" >/dev/null
  cmake --build "$BUILD_DIR" -j"$JOBS" --target test_slam_e2e test_local_mapper test_rawlog \
    test_global_ba_writeback test_places_e2e features_test_orb_extractor test_outputs
  built=$(date +%s)
  export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/scripts/tsan.supp}
  export OPENCV_FOR_THREADS_NUM=1
  # SuiteSparse's CHOLMOD (local BA's sparse Cholesky) runs OpenMP threads; uninstrumented libgomp hides their
  # synchronization from TSan, which then reports CHOLMOD's own buffers as races. One OpenMP thread (CHOLMOD
  # asks for its own thread count, so OMP_NUM_THREADS alone does not do it).
  export OMP_NUM_THREADS=1 OMP_THREAD_LIMIT=1
  # GTEST_FILTER: only the threaded-mode tests of the e2e binary (the others are single-threaded).
  GTEST_FILTER='*Threaded*' ctest --test-dir "$BUILD_DIR" -R '^test_slam_e2e$' --output-on-failure
  ctest --test-dir "$BUILD_DIR" -R '^test_local_mapper$' --output-on-failure
  # slam-run's frames read ahead in a thread of their own (datasets::PrefetchingRawlogReader).
  GTEST_FILTER='PrefetchingRawlogReader.*' ctest --test-dir "$BUILD_DIR" -R '^test_rawlog$' --output-on-failure
  # A loop's global BA on a thread of its own (libs/loopclosing), written back by the mapping thread.
  ctest --test-dir "$BUILD_DIR" -R '^test_global_ba_writeback$' --output-on-failure
  GTEST_FILTER='*Threaded*' ctest --test-dir "$BUILD_DIR" -R '^test_places_e2e$' --output-on-failure
  # The ORB extractor shares out its pyramid levels over [ORB] threads (every run above does too).
  GTEST_FILTER='*Threads*' ctest --test-dir "$BUILD_DIR" -R '^features_test_orb_extractor$' --output-on-failure
  # A map file's gzip blocks are compressed on threads of their own (GzipOutputStream; every map saved above too).
  GTEST_FILTER='GzipOutputStream.*' ctest --test-dir "$BUILD_DIR" -R '^test_outputs$' --output-on-failure
  done_=$(date +%s)
  echo "run-sanitizers (thread): build $((built - start)) s, tests $((done_ - built)) s"
  exit 0
fi

# -O1: the sanitizers' usual trade-off (about half the -O0 run time, stacks still readable).
# EIGEN_MALLOC_ALREADY_ALIGNED=1: under ASan Eigen switches to its own aligned allocator (it tests
# __SANITIZE_ADDRESS__), while the Debian Ceres library was built without it; memory Eigen allocates in Ceres
# and frees in our code (or the reverse) is then reported as a heap-buffer-overflow in handmade_aligned_free
# (test_optimize_residuals). With the definition our code uses glibc's malloc, which is 16-byte aligned on
# x86-64, exactly as the uninstrumented Ceres does.
FLAGS="-fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer -O1 -g1"
FLAGS="$FLAGS -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
LINK_FLAGS="-fsanitize=address,undefined"

if [[ $SCOPE == ci ]]; then
  # The libraries that parse what users hand us (rawlogs, images, maps, vocabularies, trajectories, ini files) and their
  # unit tests, the rawlog and map fuzz tests included: where the map loader's undefined behaviour was found.
  # Configuring only these components keeps the build to a fraction of the whole (doc/reliability-config.md).
  # features and geometry are configured because places (the vocabulary reader) and map link them (map holds
  # geometry::PinholeCamera, built as priorslam::camera: only that file of libs/geometry is compiled here); their
  # own tests (ORB extraction, matching, two-view geometry: no file input) stay out of this scope.
  COMPONENTS="core;datasets;eval;geometry;features;places;map"
  LABELS='^unit$'
  EXCLUDE='^(features|geometry)_'
else
  COMPONENTS=""
  # Labels unit and e2e, without external_consumer (it installs the build and compiles a consumer project
  # against it: a packaging check that runs no project code the other e2e tests do not run). Tests labelled
  # data need ../shared/data and slurm a local Slurm; the Release job runs them.
  LABELS='^(unit|e2e)$'
  EXCLUDE='^external_consumer$'
fi

start=$(date +%s)
# No Python module: a sanitized extension cannot be loaded by an interpreter built without the sanitizer runtime.
cmake -S . -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Sanitize \
  -DCMAKE_CXX_FLAGS_SANITIZE="$FLAGS" \
  -DCMAKE_EXE_LINKER_FLAGS_SANITIZE="$LINK_FLAGS" \
  -DCMAKE_SHARED_LINKER_FLAGS_SANITIZE="$LINK_FLAGS" \
  -DPRIORSLAM_COMPONENTS="$COMPONENTS" \
  -DPRIORSLAM_BUILD_BENCHMARKS=OFF -DPRIORSLAM_UNITY_BUILD=OFF -DPRIORSLAM_PYTHON=OFF "${launcher[@]}" >/dev/null

mapfile -t tests < <(ctest --test-dir "$BUILD_DIR" -N -L "$LABELS" -E "$EXCLUDE" | sed -n 's/^ *Test *#[0-9]*: //p')
[ "${#tests[@]}" -gt 0 ] || { echo "run-sanitizers: no tests found" >&2; exit 1; }
# Only what these tests need (their executables; e2e tests depend on the tools they run).
cmake --build "$BUILD_DIR" -j"$JOBS" --target "${tests[@]}"
built=$(date +%s)

export ASAN_OPTIONS=${ASAN_OPTIONS:-halt_on_error=1:detect_leaks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
ctest --test-dir "$BUILD_DIR" -L "$LABELS" -E "$EXCLUDE" --output-on-failure -j"$JOBS"
done_=$(date +%s)
echo "run-sanitizers ($SCOPE): ${#tests[@]} tests; build $((built - start)) s, tests $((done_ - built)) s"
