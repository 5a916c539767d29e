"""pybullet imported with its "pybullet build time" banner kept off the terminal.

The package imports this module before any other, so the banner (printed by pybullet's
C code at import) never comes before a command's own first line.
"""

from robot_app.console import quiet_import

pybullet = quiet_import("pybullet")
