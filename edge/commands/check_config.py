"""`mast-stereo check-config`: load a configuration and/or a calibration and print what they say.

    mast-stereo check-config [--config FILE] [--calibration FILE]

For a technician before restarting the service: the same loader the daemon
uses (edge.config.app / edge.config.calibration), so exit 0 here means the daemon will
accept the files, and any mistake is one line naming the file, the key, what
was expected and what was found, with exit status 78. The summary lists the
frame source, the rig (models, focal lengths, fields of view, rotations,
baseline), the site and the outputs.
"""

from __future__ import annotations

import argparse
import math
from dataclasses import fields
from pathlib import Path

from edge.config.app import AppConfig, ExperimentalConfig, V4l2Cameras, load_config
from edge.config.calibration import Calibration, load_calibration
from edge.core.calibfit import relative_rotation_deg
from edge.core.site import Site
from edge.errors import ConfigError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", type=Path, metavar="FILE", help="appliance configuration (YAML)")
    parser.add_argument("--calibration", type=Path, metavar="FILE", help="calibration file (YAML)")


def describe_calibration(cal: Calibration) -> list[str]:
    rig = cal.rig
    lines = [f"rig: baseline {rig.baseline_m:g} m, image {rig.width}x{rig.height}"]
    for side, cam in (("left", rig.left), ("right", rig.right)):
        f_px = cam.focal_px()
        hfov = math.degrees(2.0 * math.atan(0.5 * rig.width / f_px))
        rx, ry, rz = cam.rotation_deg
        lines.append(
            f"  {side}: {cam.to_dict()['model']}, f {f_px:.1f} px (HFOV {hfov:.1f} deg), "
            f"rotation rx {rx:.3f} ry {ry:.3f} rz {rz:.3f} deg"
        )
    rel = relative_rotation_deg(rig)
    lines.append(f"  right relative to left: rx {rel[0]:.3f} ry {rel[1]:.3f} rz {rel[2]:.3f} deg")
    if cal.site is not None:
        lines.append(f"  calibration site: {_site(cal.site)}")
    return lines


def _site(site: Site) -> str:
    return (
        f"lat {site.lat_deg:.6f}, lon {site.lon_deg:.6f}, height {site.height_m:g} m, "
        f"heading {site.heading_deg:g} deg"
    )


def describe_config(cfg: AppConfig) -> list[str]:
    cams = cfg.cameras
    if isinstance(cams, V4l2Cameras):
        rate = f"{cams.fps:g} fps" if cams.fps is not None else "the trigger's rate"
        source = (f"v4l2 {cams.left.get('device')} + {cams.right.get('device')}, {cams.width}x{cams.height} "
                  f"{cams.pixel_format} at {rate}, trigger {cams.trigger.get('kind', 'none')}")
    elif cams.kind == "replay":
        source = f"replay {cams.path}" + (" (paced)" if cams.pace else " (as fast as possible)")
    else:
        source = f"virtual scenario {cams.scenario!r}, seed {cams.seed}"
    lines = [f"cameras: {source}"]
    if cfg.calibration is None:
        lines.append("calibration: from the scenario / recording")
    else:
        lines += describe_calibration(cfg.calibration)
    site = cfg.effective_site
    lines.append(f"site: {_site(site)}" if site is not None else "site: from the scenario / recording")
    p = cfg.pipeline
    lines.append(
        f"pipeline: window {p.window}, max disparity {p.max_disparity}, "
        f"detect every {p.detect_every}, up to {p.max_tracks} tracks"
    )
    changed = {f.name: getattr(p.experimental, f.name) for f in fields(p.experimental)
               if getattr(p.experimental, f.name) != getattr(ExperimentalConfig(), f.name)}
    if changed:  # research switches away from the product: say so where a technician looks
        lines.append("experimental (not the validated product): "
                     + ", ".join(f"{k} {v}" for k, v in changed.items()))
    for i, port in enumerate(cfg.outputs.nmea):
        lines.append(
            f"nmea[{i}]: {port.url} {port.baud} {port.bytesize}{port.parity}{port.stopbits}, "
            f"{port.talker} {'+'.join(port.sentences)}"
        )
    udp, mb = cfg.outputs.udp, cfg.outputs.modbus
    if udp.enabled:
        lines.append(f"udp: IEC 61162-450 to {udp.group}:{udp.port} via {udp.interface}, ttl {udp.ttl}")
    if mb.tcp.enabled:
        lines.append(f"modbus tcp: {mb.tcp.host}:{mb.tcp.port}, word order {mb.word_order}")
    if mb.rtu.enabled:
        lines.append(
            f"modbus rtu: {mb.rtu.url} {mb.rtu.baud} 8{mb.rtu.parity}{mb.rtu.stopbits}, unit {mb.rtu.unit}"
        )
    lines.append(f"health: stale after {cfg.health.stale_s:g} s, leds {cfg.health.leds.kind}")
    return lines


def run(args: argparse.Namespace) -> int:
    if args.config is None and args.calibration is None:
        raise ConfigError("command line", "--config", "a file to check (--config and/or --calibration)")
    if args.config is not None:
        lines = describe_config(load_config(args.config))
        print(f"{args.config}: OK")
        print("\n".join(lines))
    if args.calibration is not None:
        lines = describe_calibration(load_calibration(args.calibration))
        print(f"{args.calibration}: OK")
        print("\n".join(lines))
    return 0
