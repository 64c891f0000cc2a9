"""The data types every stage shares: human marker motion
(:class:`~imesh.core.motion.MarkerMotion`), robot joint motion
(:class:`~imesh.core.robot_motion.RobotMotion`), progress reporting, the user cache and the
lazy-import helper. Imports nothing else of imesh."""
