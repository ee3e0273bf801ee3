#!/usr/bin/python3
"""Screenshot test: RViz with the package's config, under a private Xvfb, shows the tissue after a
cut (the skin colour covers a sizeable part of the picture, the cut walls show)."""
import csv
import os
import subprocess
import sys
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import PoseStamped
from visualization_msgs.msg import MarkerArray

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
import rviz_headless  # noqa: E402


def incision():
    with open(os.path.join(ROOT, "meshes", "paths", "incision_block.csv")) as f:
        return [[float(x) for x in (r["t"], r["x"], r["y"], r["z"], r["qx"], r["qy"], r["qz"], r["qw"])]
                for r in csv.DictReader(f)]


class Screenshot(unittest.TestCase):
    def setUp(self):
        # Only Debian's message packages here: catkin's run_tests gives no PYTHONPATH to this
        # package's own generated messages. The surface marker tells how many faces there are.
        self.faces = None
        rospy.Subscriber("/tissue/markers", MarkerArray, self.on_markers)
        self.pub = rospy.Publisher("/tissue/scalpel_pose", PoseStamped, queue_size=100)
        self.xvfb, self.display = rviz_headless.start_xvfb()
        env = dict(os.environ, DISPLAY=self.display)
        self.rviz = subprocess.Popen(["rviz", "-d", os.path.join(ROOT, "config", "tissue.rviz")], env=env,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def tearDown(self):
        for p in (self.rviz, self.xvfb):
            p.terminate()
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()

    def on_markers(self, msg):
        surface = [m for m in msg.markers if m.ns == "surface"]
        if surface:
            self.faces = len(surface[0].points) // 3

    def wait(self, done, timeout):
        end = time.time() + timeout
        while time.time() < end and not rospy.is_shutdown():
            if done():
                return True
            time.sleep(0.05)
        return done()

    def test_rviz_shows_the_cut_tissue(self):
        self.assertTrue(self.wait(lambda: self.faces is not None and self.pub.get_num_connections() > 0, 30),
                        "the node never published ~markers or subscribed to ~scalpel_pose")
        uncut = self.faces
        rows = incision()
        start, t0, t1 = time.time(), rows[0][0], rows[-1][0]
        while not rospy.is_shutdown():
            s = min(time.time() - start, t1 - t0)
            i = max(k for k in range(len(rows)) if rows[k][0] <= t0 + s)
            j = min(i + 1, len(rows) - 1)
            w = 0.0 if j == i else (t0 + s - rows[i][0]) / (rows[j][0] - rows[i][0])
            msg = PoseStamped()
            msg.header.stamp = rospy.Time.now()
            msg.header.frame_id = "world"
            p = [(1 - w) * a + w * b for a, b in zip(rows[i][1:4], rows[j][1:4])]
            msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = p
            msg.pose.orientation.x, msg.pose.orientation.y, msg.pose.orientation.z, msg.pose.orientation.w = rows[i][4:]
            self.pub.publish(msg)
            if s >= t1 - t0:
                break
            time.sleep(0.005)
        self.assertTrue(self.wait(lambda: self.faces > uncut + 100, 10),
                        "the incision made no cut walls (%d surface faces before, %d after)" % (uncut, self.faces))
        out = os.path.join(os.environ.get("ROS_HOME", os.path.expanduser("~/.ros")), "tissue_cut_screenshot.png")
        # RViz needs a few seconds to come up with software GL; the picture must settle.
        skin = wall = 0.0
        for _ in range(20):
            time.sleep(1.0)
            rviz_headless.screenshot(self.display, out)
            skin, wall = rviz_headless.tissue_fractions(out)
            if skin > 0.05 and wall > 0.0005:
                break
        print(f"{out}: skin {100 * skin:.1f}%, cut walls {100 * wall:.2f}% of the picture")
        self.assertGreater(skin, 0.05, "the tissue covers too little of the picture: " + out)
        self.assertGreater(wall, 0.0005, "no cut wall visible: " + out)


if __name__ == "__main__":
    rospy.init_node("screenshot_test")
    rostest.rosrun("tissue_cut", "screenshot", Screenshot, sys.argv)
