#!/usr/bin/python3
"""RViz without a screen: a private Xvfb display, a screenshot, and how much of it is tissue.

Used by scripts/demo (headless) and the screenshot rostest. As a command:
  rviz_headless.py xvfb               starts Xvfb on a free display, prints ':N PID'
  rviz_headless.py shot :N OUT.png    screenshot of display :N, prints the tissue fractions
"""
import os
import subprocess
import sys

# The node's marker colours (src/ros/surface_markers.cpp), before RViz's lighting.
SKIN = (0.93, 0.67, 0.60)
WALL = (0.62, 0.08, 0.12)


def start_xvfb(width=1000, height=700):
    """Starts Xvfb on the first free display; returns (process, ':N')."""
    read_fd, write_fd = os.pipe()
    proc = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write_fd), "-screen", "0", f"{width}x{height}x24", "-nolisten", "tcp"],
        pass_fds=(write_fd,), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_fd)
    with os.fdopen(read_fd) as f:
        number = f.readline().strip()
    if not number:
        proc.kill()
        raise RuntimeError("Xvfb did not start (is the xvfb package installed?)")
    return proc, ":" + number


def screenshot(display, out):
    subprocess.run(["import", "-display", display, "-window", "root", out], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def tissue_fractions(path):
    """Fractions of the picture whose hue is the skin's or the cut walls' (shaded by RViz)."""
    from PIL import Image
    import numpy as np
    img = np.asarray(Image.open(path).convert("RGB")).astype(float) / 255.0
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    lit = np.maximum(np.maximum(r, g), b) > 0.15

    def like(color):
        # Same hue and saturation under a brightness change: compare normalised colours.
        s = np.maximum(r + g + b, 1e-6)
        c = sum(color)
        return lit & (abs(r / s - color[0] / c) < 0.05) & (abs(g / s - color[1] / c) < 0.05) & \
            (abs(b / s - color[2] / c) < 0.05)

    n = r.size
    return float(like(SKIN).sum()) / n, float(like(WALL).sum()) / n


def main(argv):
    if len(argv) >= 2 and argv[1] == "xvfb":
        proc, display = start_xvfb()
        print(display, proc.pid)
        return 0
    if len(argv) == 4 and argv[1] == "shot":
        screenshot(argv[2], argv[3])
        skin, wall = tissue_fractions(argv[3])
        print(f"{argv[3]}: skin {100 * skin:.1f}% of the picture, cut walls {100 * wall:.2f}%")
        return 0
    print(__doc__, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
