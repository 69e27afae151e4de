#!/usr/bin/python3
# rostest (python_client.test): the node seen from Debian's rospy, as a user's node sees it.
# (/usr/bin/python3 on purpose: a pyenv python3 first on PATH cannot import Debian's rospy.)
import math
import sys
import threading
import unittest

import rospy
import rostest
from std_srvs.srv import Trigger
from wet_curly_hair.msg import Status, Strands
from wet_curly_hair.srv import GetParameters, SetParameters, SetSaturation, SetSaturationRequest

NODE = "/wet_curly_hair"


class Latest:
    """Keeps the newest message of a topic."""

    def __init__(self, topic, cls):
        self.cond = threading.Condition()
        self.msg, self.count = None, 0
        self.sub = rospy.Subscriber(topic, cls, self._cb, queue_size=10)

    def _cb(self, msg):
        with self.cond:
            self.msg, self.count = msg, self.count + 1
            self.cond.notify_all()

    def next(self, timeout=20.0, pred=lambda m: True):
        with self.cond:
            seen = self.count
            ok = self.cond.wait_for(lambda: self.count > seen and pred(self.msg), timeout)
            return self.msg if ok else None


class PythonClient(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("python_client", anonymous=True)
        cls.strands = Latest(NODE + "/strands", Strands)
        cls.status = Latest(NODE + "/status", Status)
        for name in ["get_parameters", "set_parameters", "set_saturation", "reset"]:
            rospy.wait_for_service(NODE + "/" + name, timeout=30.0)
        cls.get = rospy.ServiceProxy(NODE + "/get_parameters", GetParameters)
        cls.set = rospy.ServiceProxy(NODE + "/set_parameters", SetParameters)
        cls.sat = rospy.ServiceProxy(NODE + "/set_saturation", SetSaturation)
        cls.reset = rospy.ServiceProxy(NODE + "/reset", Trigger)

    def test_strands_decode_with_consistent_sizes(self):
        m = self.strands.next(30.0)
        self.assertIsNotNone(m, "no strands message")
        offsets = list(m.strand_offsets)
        self.assertEqual(len(offsets), 17)
        self.assertEqual(offsets[0], 0)
        n = offsets[-1]
        self.assertEqual(n, 16 * 12)
        self.assertEqual(len(m.positions), 3 * n)
        self.assertEqual(len(m.saturation), n)
        self.assertIn(len(m.wet_positions), (0, 3 * n))
        self.assertEqual(m.header.frame_id, "world")
        self.assertTrue(all(math.isfinite(x) for x in m.positions))
        # a strand as a list of points, the way a user would take it apart
        s = 3
        pts = [m.positions[3 * i:3 * i + 3] for i in range(offsets[s], offsets[s + 1])]
        self.assertEqual(len(pts), 12)

    def test_status(self):
        s = self.status.next(30.0, lambda m: m.step > 0)
        self.assertIsNotNone(s, "no status")
        self.assertEqual(s.particles, 16 * 12)
        self.assertGreater(s.substeps, 0)

    def test_parameters_round_trip(self):
        r = self.set(names=["solver.core.stiffness_n"], values=[0.45],
                     string_names=[], string_values=[])
        self.assertTrue(r.success, r.message)
        g = self.get(names=["solver.core.stiffness_n", "solver.cohesion.mode"])
        self.assertTrue(g.success, g.message)
        self.assertEqual(g.values[0], 0.45)
        self.assertTrue(math.isnan(g.values[1]))
        self.assertEqual(g.string_values[1], "ours")
        self.assertEqual(g.types, ["double", "string"])
        self.assertEqual(rospy.get_param(NODE + "/solver/core/stiffness_n"), 0.45)
        bad = self.set(names=["solver.core.stiffness_n"], values=[float("nan")],
                       string_names=[], string_values=[])
        self.assertFalse(bad.success)
        self.assertIn("solver.core.stiffness_n", bad.message)
        self.assertEqual(self.get(names=["solver.core.stiffness_n"]).values[0], 0.45)

    def test_saturation_and_reset(self):
        req = SetSaturationRequest(strands=[0, 1], root_value=0.0, tip_value=1.0)
        r = self.sat(req)
        self.assertTrue(r.success, r.message)
        self.assertEqual(r.particles_changed, 2 * 12)
        # A message published just before the call can still reach the callback after it (the
        # subscriber's thread): wait for the first one that carries the change, then check that
        # the next one keeps it (one connection delivers in order).
        m = self.strands.next(20.0, lambda m: abs(m.saturation[11] - 1.0) < 1e-6)
        self.assertIsNotNone(m, "the tip of strand 0 never reached saturation 1")
        self.assertEqual(m.saturation[12], 0.0)  # root of strand 1
        m = self.strands.next(20.0)
        self.assertAlmostEqual(m.saturation[11], 1.0, places=6)  # tip of strand 0
        self.assertEqual(m.saturation[12], 0.0)
        bad = self.sat(SetSaturationRequest(strands=[99], root_value=0.5, tip_value=0.5))
        self.assertFalse(bad.success)
        self.assertIn("99", bad.message)
        g = self.get(names=["saturation.root", "saturation.tip"])
        self.assertNotAlmostEqual(g.values[1], 1.0, places=6)  # else the reset would not show
        t = self.reset()
        self.assertTrue(t.success, t.message)
        # back to the scene's initial root-to-tip ramp (the same in-flight message caveat)
        m = self.strands.next(20.0, lambda m: abs(m.saturation[11] - g.values[1]) < 1e-6)
        self.assertIsNotNone(m, "the tip of strand 0 never went back to the scene's ramp")
        self.assertAlmostEqual(m.saturation[0], g.values[0], places=6)
        m = self.strands.next(20.0)
        self.assertAlmostEqual(m.saturation[0], g.values[0], places=6)
        self.assertAlmostEqual(m.saturation[11], g.values[1], places=6)


if __name__ == "__main__":
    rostest.rosrun("wet_curly_hair", "python_client", PythonClient, sys.argv)
