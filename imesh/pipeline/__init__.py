"""The pipelines that compose the stages: :mod:`~imesh.pipeline.retarget` (one clip, human motion
-> verified robot motion) and :mod:`~imesh.pipeline.batch` (many clips on Ray)."""
