#!/usr/bin/env bash
# The solver library, the file formats, the runner harness and the viewer stay free of ROS: every
# #include under include/wet_curly_hair/{core,io,runner,viewer} and src/{core,io,runner,viewer}
# must come from an allowlist of include roots, so that a ROS header, or any other new
# dependency, fails here with the offending line.
#   core: standard C and C++ headers, Eigen, OpenMP (omp.h), the compiler's x86 headers
#         (immintrin.h, cpuid.h), dynamicEDT3D, the package's own core headers, and files
#         beside the including file.
#   io:   all of the above, plus yaml-cpp, OctoMap, POSIX file-system headers and the package's
#         own io headers.
#   runner: all of io's, plus the package's own runner headers.
#   viewer: all of io's, plus Cairo and the package's own viewer headers.
# A layer including a later layer's header is refused too (io builds on core, never the reverse).
set -u
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
exec /usr/bin/python3 - "$@" <<'PY'
import os
import re
import sys

# C++17 standard library headers and the C library headers they include (both spellings).
CXX = """algorithm any array atomic bitset cassert cctype cerrno cfenv cfloat charconv chrono cinttypes
climits clocale cmath codecvt complex condition_variable csetjmp csignal cstdarg cstddef cstdint
cstdio cstdlib cstring ctime cuchar cwchar cwctype deque exception execution filesystem
forward_list fstream functional future initializer_list iomanip ios iosfwd iostream istream
iterator limits list locale map memory memory_resource mutex new numeric optional ostream queue
random ratio regex scoped_allocator set shared_mutex sstream stack stdexcept streambuf string
string_view system_error thread tuple type_traits typeindex typeinfo unordered_map unordered_set
utility valarray variant vector""".split()
C = """assert.h ctype.h errno.h fenv.h float.h inttypes.h limits.h locale.h math.h setjmp.h signal.h
stdarg.h stddef.h stdint.h stdio.h stdlib.h string.h time.h uchar.h wchar.h wctype.h""".split()
STANDARD = set(CXX) | set(C)
POSIX = {"unistd.h", "fcntl.h", "sys/stat.h", "sys/types.h"}

CORE_DIRS = ["include/wet_curly_hair/core", "src/core"]
IO_DIRS = ["include/wet_curly_hair/io", "src/io"]
RUNNER_DIRS = ["include/wet_curly_hair/runner", "src/runner"]
VIEWER_DIRS = ["include/wet_curly_hair/viewer", "src/viewer"]
INCLUDE = re.compile(r'^\s*#\s*include\b(.*)$')
TARGET = re.compile(r'^\s*([<"])([^>"]+)[>"]')


def allowed(layer, path, bracket, name):
    """Why the include is allowed, or None."""
    if bracket == '"' and os.path.isfile(os.path.join(os.path.dirname(path), name)):
        return "beside the including file"
    if name in STANDARD:
        return "standard"
    if name.startswith(("Eigen/", "unsupported/Eigen/")):
        return "Eigen"
    if name in ("omp.h", "immintrin.h", "cpuid.h"):
        return "OpenMP / intrinsics"
    if name.startswith("dynamicEDT3D/"):
        return "dynamicEDT3D"
    if name.startswith("wet_curly_hair/core/"):
        return "own core header"
    if layer == "runner" and name.startswith("wet_curly_hair/runner/"):
        return "own runner header"
    if layer == "viewer":
        if name.startswith("wet_curly_hair/viewer/"):
            return "own viewer header"
        if name == "cairo.h" or name.startswith("cairo/"):
            return "Cairo (viewer)"
    if layer in ("io", "runner", "viewer"):
        if name.startswith("wet_curly_hair/io/"):
            return "own io header"
        if name.startswith("yaml-cpp/"):
            return "yaml-cpp"
        if name.startswith("octomap/"):
            return "OctoMap"
        if name in POSIX:
            return "POSIX"
    return None


def check(layer, dirs):
    files, bad = 0, []
    for d in dirs:
        if not os.path.isdir(d):
            bad.append("%s: directory missing" % d)
            continue
        for root, _, names in os.walk(d):
            for n in sorted(names):
                if not n.endswith((".h", ".hpp", ".cpp", ".cc", ".inc")):
                    continue
                path = os.path.join(root, n)
                files += 1
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        t = TARGET.match(m.group(1))
                        if not t or not allowed(layer, path, t.group(1), t.group(2)):
                            bad.append("%s:%d: %s" % (path, number, line.strip()))
    return files, bad


core_files, core_bad = check("core", CORE_DIRS)
io_files, io_bad = check("io", IO_DIRS)
runner_files, runner_bad = check("runner", RUNNER_DIRS)
viewer_files, viewer_bad = check("viewer", VIEWER_DIRS)
bad = core_bad + io_bad + runner_bad + viewer_bad
# A check that read nothing has not passed.
if core_files < 10 or io_files < 5 or runner_files < 2 or viewer_files < 2:
    bad.append("only %d core, %d io, %d runner and %d viewer files found: wrong directory?"
               % (core_files, io_files, runner_files, viewer_files))
print("checked %d core, %d io, %d runner and %d viewer files"
      % (core_files, io_files, runner_files, viewer_files))
if bad:
    print("includes outside the allowlist of the ROS-free layers:")
    for b in bad:
        print("  " + b)
    print("0 passed, 1 failed")
    sys.exit(1)
print("1 passed, 0 failed")
PY
