"""Order of the Python tests. They run in three processes (cmake/tests.cmake: pytest -n 3 --dist
worksteal), each starting on its third of the queue. The files listed here drive robots in wall
time for minutes with little CPU; queued first, they run beside the rest instead of after it."""
import os

WALL_TIME_FIRST = ("test_nav_vs_stock_short.py",)


def pytest_collection_modifyitems(session, config, items):
    items.sort(key=lambda item: os.path.basename(str(item.fspath)) not in WALL_TIME_FIRST)   # a stable sort
