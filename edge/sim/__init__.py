"""The scene simulator: a physically honest stereo sea scene with ground truth.

Both views are ray-cast from the geometry through the calibration (never one
resampled from the other): `scene` (Earth, sky, sea, fog), `ships` (3-D hulls
on scripted tracks), `render` (per-camera area-integrated radiance),
`imaging` (PSF, noise, 8-bit), `scenario` (YAML), `simulator` (frames, truth,
timing) and `recording` (the recording directory of docs/recordings.md).
"""
