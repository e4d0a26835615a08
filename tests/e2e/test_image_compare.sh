#!/usr/bin/env bash
# opaline-image-compare (docs/testing.md) on synthesized images, independent of the renderer: a
# reference, the variance of one sample (in Mitsuba's XYZ convention, and per stored channel),
# and "renders" drawn as the reference plus normal noise of that variance / N. A correct render
# passes at the stated rate (the failures over 50 seeds near alpha, at two alphas), a 3 % bias
# in one 16 x 16 region fails there, a render of fewer samples than claimed fails, the
# reference's own noise is counted with --ref-spp, and bad input exits 2 with a message naming
# what is wrong. The seeds are fixed: the outcome is the same on every run.
set -uo pipefail
source "$(dirname "$0")/e2e_support.sh"
e2e_setup image_compare opaline-image-compare
export COMPARE=$BIN/opaline-image-compare T

python3 - <<'PY'
import math, os, random, struct, subprocess, sys, zlib

T, COMPARE = os.environ["T"], os.environ["COMPARE"]
W = H = 48
failures = []

# XYZ <-> sRGB, the matrices of Mitsuba's moment integrator and render tests.
TO_XYZ = ((0.412453, 0.357580, 0.180423), (0.212671, 0.715160, 0.072169),
          (0.019334, 0.119193, 0.950227))
TO_RGB = ((3.240479, -1.537150, -0.498535), (-0.969256, 1.875991, 0.041556),
          (0.055648, -0.204043, 1.057311))

def mul(m, v):
    return [m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3)]

def write_pfm(path, pixels, w=W, h=H, ch=3):
    """pixels: rows from the top, each a list of w pixels of ch floats."""
    with open(path, "wb") as f:
        f.write(b"%s\n%d %d\n-1.0\n" % (b"PF" if ch == 3 else b"Pf", w, h))
        for row in reversed(pixels):
            for p in row:
                f.write(struct.pack("<%df" % ch, *p))

def write_png(path, w, h):
    raw = b"".join(b"\0" + bytes([128] * 3 * w) for _ in range(h))
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(
            ">I", zlib.crc32(kind + data) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))

# The truth in XYZ: a smooth colour ramp, black (noiseless) in its top 8 rows; the variance of
# one sample is 0.3 x value^2 + 0.002 per channel (a relative standard deviation near 55 %).
truth = [[[0.0] * 3 if y < 8 else
          [0.2 + 0.6 * x / W, 0.3 + 0.4 * y / H, 0.5 + 0.3 * math.sin(0.2 * (x + y))]
          for x in range(W)] for y in range(H)]
var_xyz = [[[0.0] * 3 if y < 8 else [0.3 * v * v + 0.002 for v in truth[y][x]]
            for x in range(W)] for y in range(H)]
write_pfm(T + "/ref.pfm", [[mul(TO_RGB, p) for p in row] for row in truth])
write_pfm(T + "/var.pfm", [[mul(TO_RGB, v) for v in row] for row in var_xyz])   # Mitsuba's way
write_pfm(T + "/ref_rgbspace.pfm", truth)                                        # for --space rgb
write_pfm(T + "/var_rgbspace.pfm", var_xyz)

def noisy(seed, spp, mean=truth, bias=None):
    """XYZ pixels: mean + normal noise of variance var / spp; bias (x0, y0, side, factor)
    scales the mean of a square region."""
    rng = random.Random(seed)
    out = []
    for y in range(H):
        row = []
        for x in range(W):
            m = mean[y][x]
            if bias and bias[0] <= x < bias[0] + bias[2] and bias[1] <= y < bias[1] + bias[2]:
                m = [v * bias[3] for v in m]
            row.append([m[c] + rng.gauss(0, math.sqrt(var_xyz[y][x][c] / spp)) for c in range(3)])
        out.append(row)
    return out

def write_render(name, xyz, rgb_space=False):
    path = "%s/%s.pfm" % (T, name)
    write_pfm(path, xyz if rgb_space else [[mul(TO_RGB, p) for p in row] for row in xyz])
    return path

def run(args, ref="ref.pfm", var="var.pfm"):
    p = subprocess.run([COMPARE] + args + [T + "/" + ref, T + "/" + var],
                       capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr

def check(ok, what, detail=""):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)
        if detail:
            print("    " + detail.replace("\n", "\n    "))

def figure(out, name):
    for line in out.splitlines():
        if line.startswith(name + ": "):
            return line[len(name) + 2:]
    return ""

# 1. Correct renders at 16 spp over 50 seeds; the reference's noise at 16 spp over the same
#    seeds (a noisy reference, counted with --ref-spp or not).
SEEDS, SPP = range(50), 16
counts = {"0.01": 0, "0.25": 0, "refnoise": 0, "refnoise-uncounted": 0}
for seed in SEEDS:
    render = write_render("r", noisy(1000 + seed, SPP))
    for alpha in ("0.01", "0.25"):
        rc, out, err = run(["--spp", str(SPP), "--alpha", alpha, render])
        if rc not in (0, 1):
            check(False, "correct render, seed %d: exit %d" % (seed, rc), err)
        counts[alpha] += rc == 1
    write_render("noisyref", noisy(5000 + seed, SPP))
    for key, extra in (("refnoise", ["--ref-spp", str(SPP)]), ("refnoise-uncounted", [])):
        rc, out, err = run(["--spp", str(SPP), "--alpha", "0.25"] + extra + [render],
                           ref="noisyref.pfm")
        counts[key] += rc == 1
print("failures of 50 correct renders: %d at alpha 0.01, %d at alpha 0.25; against a 16-spp "
      "reference: %d with --ref-spp 16, %d without" % (counts["0.01"], counts["0.25"],
      counts["refnoise"], counts["refnoise-uncounted"]))
# Binomial(50, alpha): 0.5 +- 0.7 expected at 0.01, 12.5 +- 3.1 at 0.25. The bounds hold for a
# calibrated test with probability 0.998 and 0.995; a test that is too lenient (never fails) or
# too strict fails them.
check(counts["0.01"] <= 3, "alpha 0.01: at most 3 of 50 correct renders fail")
check(5 <= counts["0.25"] <= 20, "alpha 0.25: 5 to 20 of 50 correct renders fail")
check(5 <= counts["refnoise"] <= 20, "noisy reference, --ref-spp counts its noise: 5 to 20 of 50")
check(counts["refnoise-uncounted"] >= 40,
      "noisy reference, its noise not counted: most of 50 fail (the test assumed too little noise)")

# 2. A 3 % bias in the 16 x 16 region x, y in 16..31 (blocks 2..3 of 8 pixels) at 256 spp fails,
#    and the worst block lies in that region (a block's mean there has a relative standard
#    deviation near 0.55 / sqrt(64 x 256) = 0.4 %: the bias is 7 of them, the limit near 3.9).
render = write_render("bias", noisy(7, 256, bias=(16, 16, 16, 1.03)))
rc, out, err = run(["--spp", "256", render])
worst = figure(out, "max |z|")
check(rc == 1 and figure(out, "result") == "fail", "3 % bias in a 16 x 16 region: fails", out + err)
check(any(("block (%d, %d)" % (bx, by)) in worst for bx in (2, 3) for by in (2, 3)),
      "3 %% bias: the worst block is in the biased region (%s)" % worst)
rc, out, err = run(["--spp", "256", write_render("nobias", noisy(7, 256))])
check(rc == 0, "the same render without the bias: passes", out + err)

# 3. The spp claimed: a 4-spp render passes as 4 spp and fails as 64.
render = write_render("spp4", noisy(11, 4))
rc, out, err = run(["--spp", "4", render])
check(rc == 0, "4-spp render claimed 4 spp: passes", out + err)
rc, out, err = run(["--spp", "64", render])
check(rc == 1, "4-spp render claimed 64 spp: fails", out + err)

# 4. Pixels (--block 1, as Mitsuba's test) and a crop window (--crop), on a 64-spp render.
render_xyz = noisy(13, 64)
render = write_render("r64", render_xyz)
rc, out, err = run(["--spp", "64", "--block", "1", render])
check(rc == 0 and "48 x 48 of 1 x 1 pixels" in out, "--block 1: a correct render passes", out + err)
crop = [row[8:32] for row in render_xyz[16:40]]
write_pfm(T + "/crop.pfm", [[mul(TO_RGB, p) for p in row] for row in crop], 24, 24)
rc, out, err = run(["--spp", "64", "--crop", "8,16", T + "/crop.pfm"])
check(rc == 0, "--crop 8,16: a correct 24 x 24 window passes", out + err)
rc, out, err = run(["--spp", "64", "--crop", "16,8", T + "/crop.pfm"])
check(rc == 1, "--crop 16,8: the same window placed wrongly fails", out + err)

# 5. Variance per stored channel (--space rgb).
rc, out, err = run(["--spp", "16", "--space", "rgb",
                    write_render("rgbspace", noisy(17, 16), rgb_space=True)],
                   ref="ref_rgbspace.pfm", var="var_rgbspace.pfm")
check(rc == 0 and figure(out, "space") == "rgb", "--space rgb: a correct render passes", out + err)
rc, out, err = run(["--spp", "16", "--space", "rgb",
                    write_render("rgbbias", noisy(17, 16, bias=(16, 16, 16, 1.2)), rgb_space=True)],
                   ref="ref_rgbspace.pfm", var="var_rgbspace.pfm")
check(rc == 1, "--space rgb: a 20 % bias fails", out + err)

# 6. A render that is not finite somewhere fails (it is a result, not bad input).
bad = noisy(19, 16)
bad[30][30][0] = float("nan")
rc, out, err = run(["--spp", "16", write_render("nan", bad)])
check(rc == 1 and "non-finite render samples: " in out, "a NaN in the render: fails", out + err)

# 7. Bad input: exit 2 and one error line naming the problem.
write_pfm(T + "/small.pfm", [[[0.5] * 3] * 32] * 32, 32, 32)
write_pfm(T + "/grey.pfm", [[[0.5]] * W] * H, W, H, 1)
nanref = [[mul(TO_RGB, p) for p in row] for row in truth]
nanref[20][20][1] = float("inf")
write_pfm(T + "/nanref.pfm", nanref)
write_png(T + "/render.png", W, H)
with open(T + "/garbage.exr", "wb") as f:
    f.write(b"not an image at all\n" * 10)
good = write_render("good", noisy(23, 16))
cases = [
    (["--spp", "16", T + "/small.pfm"], "ref.pfm", "var.pfm", "the render is 32 x 32",
     "a smaller render without --crop"),
    (["--spp", "16", "--crop", "20,0", T + "/small.pfm"], "ref.pfm", "var.pfm", "does not fit",
     "a crop window outside the reference"),
    (["--spp", "16", good], "ref.pfm", "small.pfm", "the variance image is 32 x 32",
     "a variance image of another size"),
    (["--spp", "16", T + "/grey.pfm"], "ref.pfm", "var.pfm", "grey compares only with grey",
     "a grey render against an RGB reference"),
    (["--spp", "16", good], "nanref.pfm", "var.pfm", "pixel (20, 20) channel 1 is not finite",
     "a reference that is not finite"),
    (["--spp", "16", T + "/render.png"], "ref.pfm", "var.pfm", "8-bit",
     "an 8-bit PNG render"),
    (["--spp", "16", T + "/garbage.exr"], "ref.pfm", "var.pfm", "garbage.exr",
     "a file that is no image"),
    (["--spp", "16", T + "/missing.exr"], "ref.pfm", "var.pfm", "missing.exr",
     "a missing file"),
    ([good], "ref.pfm", "var.pfm", "need --spp N", "no --spp"),
    (["--spp", "0", good], "ref.pfm", "var.pfm", "--spp 0", "--spp 0"),
    (["--spp", "16", "--alpha", "1", good], "ref.pfm", "var.pfm", "--alpha 1", "--alpha 1"),
    (["--spp", "16", "--space", "lab", good], "ref.pfm", "var.pfm", "--space lab",
     "an unknown --space"),
    (["--spp", "16", "--crop", "3", good], "ref.pfm", "var.pfm", "--crop 3", "--crop without Y"),
    (["--spp", "16", good, "--sp"], "ref.pfm", "var.pfm", "unknown option --sp",
     "an unknown option"),
    (["--spp", "16", "--var-floor", "-1", good], "ref.pfm", "var.pfm", "--var-floor -1",
     "a negative --var-floor"),
]
for args, ref, var, needle, what in cases:
    rc, out, err = run(args, ref=ref, var=var)
    errors = [l for l in err.splitlines() if l.startswith("opaline: error: ")]
    check(rc == 2 and len(errors) == 1 and needle in err and "result:" not in out,
          "bad input, %s: exit 2 naming '%s'" % (what, needle), "exit %d\n%s%s" % (rc, out, err))

p = subprocess.run([COMPARE, "--help"], capture_output=True, text=True)
check(p.returncode == 0 and "Sidak" in p.stdout, "--help prints the usage and exits 0")

if failures:
    print("%d checks failed" % len(failures))
    sys.exit(1)
PY
