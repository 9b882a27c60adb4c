"""Two lidars on one scan topic and a mapper (examples/redundant.arch)."""
from __future__ import annotations

from reconf_ros import Component

SCAN = "sensor_msgs/msg/LaserScan"
MAP = "nav_msgs/msg/OccupancyGrid"


def _lidar(name: str, hz: float, replaces: str | None = None) -> Component:
    comp = Component(name, replaces=replaces)
    scan = comp.create_output("scan", SCAN, alias="Scan")
    sense = comp.create_functionality("sense", outputs=[scan])
    sense.set_normal_mode(lambda: scan.write(scan.new(range_max=10.0)), rate=hz, outputs=[scan])
    sense.set_degraded_mode()
    return comp


def lidar_front() -> Component:
    return _lidar("lidar_front", 20)


def lidar_rear() -> Component:
    return _lidar("lidar_rear", 10)


def lidar_rear_v2() -> Component:
    return _lidar("lidar_rear_v2", 10, replaces="lidar_rear")


def mapper() -> Component:
    comp = Component("mapper")
    scan = comp.create_input("scan", SCAN, rate=10, alias="Scan")
    grid = comp.create_output("map", MAP, alias="Map")
    fn = comp.create_functionality("map", inputs=[scan], outputs=[grid], criticality=2)
    fn.set_normal_mode(lambda: grid.write(grid.new()), rate=1, outputs=[grid])
    fn.set_degraded_mode()
    return comp
