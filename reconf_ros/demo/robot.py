"""The obstacle detector and motor controller of paper 001 §3.1 (examples/robot.arch)."""
from __future__ import annotations

from reconf_ros import Component

OBSTACLES = "geometry_msgs/msg/PoseArray"
TWIST = "geometry_msgs/msg/Twist"


def obstacle_detector() -> Component:
    comp = Component("obstacle_detector", host="jetson")
    out = comp.create_output("out", OBSTACLES, alias="Obstacles")
    detect = comp.create_functionality("detect", outputs=[out], criticality=3)
    # The camera is the environment's (Image @ 30 Hz): assumed, not an input port.
    image = comp.message("Image", "sensor_msgs/msg/Image")
    detect.set_normal_mode(lambda: out.write(out.new()), rate=1, outputs=[out], assumes=[f"{image} @ 15 Hz"])
    detect.set_degraded_mode()
    return comp


def motor_controller() -> Component:
    comp = Component("motor_controller", host="base")
    inp = comp.create_input("in", OBSTACLES, rate=1, alias="Obstacles")
    cmd = comp.create_output("cmd", TWIST, alias="Twist")
    control = comp.create_functionality("control", inputs=[inp], outputs=[cmd], criticality=5)

    def drive() -> None:
        msg = cmd.new()
        seen = inp.read()
        msg.linear.x = 0.5 if seen is not None and not seen.poses else 0.0
        cmd.write(msg)

    control.set_normal_mode(drive, rate=20, outputs=[cmd], assumes=["Obstacles @ 1 s"])
    control.set_degraded_mode(lambda: cmd.write(cmd.new()), rate=20, outputs=[cmd])   # zero velocities: stop
    return comp


def base_driver() -> Component:
    comp = Component("base_driver", host="base")
    vel = comp.create_input("cmd_vel", TWIST, rate=10, alias="Twist")
    drive = comp.create_functionality("drive", inputs=[vel], criticality=5)
    drive.set_normal_mode(lambda msg: None)
    drive.set_degraded_mode()
    return comp
