"""The recording format: a directory of PNG pairs with frames.csv, meta.yaml and optional truth and AIS.

One writer and one reader (`format`), the `record` command's capture loop (`capture`) and the
daemon's live recording (`live`). The frame-level reader the replay camera uses lives in
`drivers.camera.replay`, since drivers never import edge.
"""
