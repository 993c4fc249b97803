"""Frame-pair sources: V4L2 cameras, recordings on disk, and live virtual scenes."""
