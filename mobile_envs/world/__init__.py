"""The world robots drive in: paths, their compiled geometry, path files and mazes."""
