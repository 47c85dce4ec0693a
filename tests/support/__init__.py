"""What more than one test area needs that is not a fixture: data locations, browser settings, harnesses.

Nothing here ships in the package, and nothing under ``tests/`` imports ``paramdds.bench``
(``tests/test_house.py``): a test runs a benchmark as a user does, ``paramdds bench ... --quick``,
and the rclpy host that ``paramdds bench ros2`` starts as a program
(``python -m paramdds.bench.ros2_host``).
"""
