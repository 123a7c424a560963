#!/usr/bin/env bash
# Run the whole test suite inside the workspace environment; extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
# A domain of its own keeps this run's nodes apart from anything else on the machine; each
# pytest-xdist worker takes the next one (test/conftest.py).
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$(( (RANDOM % 80) + 10 ))}"
export PYTHONDONTWRITEBYTECODE=1
# The compiled kernel is held to its Python description to 1e-9 (test_kernel.py), which takes
# the same last bits from both. On an AVX-512 CPU numpy's AVX-512 kernels (exp, sums) and
# OpenBLAS's SkylakeX kernels round differently from the C kernel's libm and loops, and the
# narrow fits grow that ulp to 1e-7 (18 of test_kernel's cases on an AMD EPYC with AVX-512):
# there the run takes numpy's and OpenBLAS's AVX2 paths, as on every CPU without AVX-512.
if grep -qw avx512f /proc/cpuinfo 2>/dev/null; then
  export OPENBLAS_CORETYPE="${OPENBLAS_CORETYPE:-Haswell}"
  if [ -z "${NPY_DISABLE_CPU_FEATURES+set}" ]; then
    NPY_DISABLE_CPU_FEATURES="$(tools/with-env.sh python -c '
import numpy
try:
    from numpy._core import _multiarray_umath as umath
except ImportError:  # numpy 1.x
    from numpy.core import _multiarray_umath as umath
print(" ".join(f for f in umath.__cpu_dispatch__ if "AVX512" in f or f == "X86_V4"))')"
    export NPY_DISABLE_CPU_FEATURES
  fi
fi
# The firmware first: its set-up (as root it installs the ARM toolchain, cmocka and QEMU), the
# core's host tests and every board's image. Without them and not root, setup-firmware.sh says
# in one line what is missing and the firmware steps are skipped (test/firmware skips too).
set +e
bash tools/setup-firmware.sh
fw=$?
set -e
case $fw in
  0) bash tools/build-firmware.sh --test ;;
  1) ;;
  *) exit "$fw" ;;
esac
set +e
tools/with-env.sh python -m pytest -n "${SKIN_TEST_WORKERS:-2}" "$@"
rc=$?
set -e
if [ "$rc" -eq 5 ]; then
  echo "run-tests: pytest collected no test; that is a failure here" >&2
  exit 1
fi
exit "$rc"
