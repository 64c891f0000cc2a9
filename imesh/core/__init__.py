"""The data types every stage shares: human marker motion
(:class:`~imesh.core.motion.MarkerMotion`), robot joint motion
(:class:`~imesh.core.robot_motion.RobotMotion`), joint limits and the options that enforce
them (:mod:`~imesh.core.limits`), progress reporting, the user cache and the lazy-import
helper. Imports nothing else of imesh but :mod:`imesh.errors`."""
