"""environment.py - the machine and the library versions the figures were measured with."""

import os
import platform
import shutil
import subprocess
import sys
import time


def environment(tool, root):
    env = {"time_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
           "platform": platform.platform(), "machine": platform.machine(),
           "cpus": os.cpu_count(), "python": sys.version.split()[0],
           "python_executable": sys.executable}
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                env["cpu"] = line.split(":", 1)[1].strip()
                break
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                env["memory_kib"] = int(line.split()[1])
    except OSError:
        pass
    env["load_average"] = os.getloadavg()
    try:
        env["opaline_factor"] = subprocess.run([tool, "--version"], capture_output=True,
                                               text=True).stdout.strip()
    except OSError:
        pass
    if shutil.which("git"):
        g = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True,
                           text=True)
        d = subprocess.run(["git", "-C", root, "status", "--porcelain"], capture_output=True,
                           text=True)
        if g.returncode == 0:
            env["source_commit"] = g.stdout.strip() + (" (modified)" if d.stdout.strip() else "")
    env["thread_env"] = {k: os.environ[k] for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")
                         if k in os.environ}
    pkgs = ["libopenblas0-pthread", "libopenblas0-openmp", "libopenblas0-serial", "liblapacke",
            "libembree3-3", "embree-tools", "blender", "python3-numpy", "python3-scipy",
            "python3-sklearn", "python3-matplotlib", "libpng16-16", "zlib1g", "libc6"]
    if shutil.which("dpkg-query"):
        p = subprocess.run(["dpkg-query", "-W", "-f", "${Package} ${Status} ${Version}\n"] + pkgs,
                           capture_output=True, text=True)
        env["debian_packages"] = {ln.split()[0]: ln.split()[-1] for ln in p.stdout.splitlines()
                                  if " installed " in ln}
    for lib in ("libblas.so.3", "liblapack.so.3"):
        p = os.path.join("/usr/lib", platform.machine() + "-linux-gnu", lib)
        if os.path.exists(p):
            env.setdefault("blas_alternatives", {})[lib] = os.path.realpath(p)
    for mod in ("numpy", "scipy", "sklearn", "matplotlib"):
        m = sys.modules.get(mod)
        if m is not None:
            env.setdefault("python_modules", {})[mod] = m.__version__
    return env
