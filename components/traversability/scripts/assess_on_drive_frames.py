#!/usr/bin/env python3
"""Scores `regolith assess`'s per-image rock list on the frames of recorded drives with exact truth
(the development set's traverse/traverse_dev_<i> format: frames/, input.json, truth_poses.csv,
truth.json). Every STEP-th frame is assessed with a scene file made from the drive's camera, the
true camera pose (height over the ground under the rover, pitch, roll) and the sun turned into the
camera's heading; each true rock near the camera is projected into the frame (a half-ellipsoid
sampled on three rings and its top) and a reported box matches a rock when their IoU exceeds 0.2.
Prints, for contrast-score floors 0..0.8, how many boxes are kept, how many lie on a rock (and on
a rock >= 10 cm) and how many on none. Plain python3, no packages.

  assess_on_drive_frames.py [--drives DIR] [--step N] [--regolith PATH] [--out DIR]
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys


def camera_axes(yaw, pitch, roll):
    fw = (math.cos(pitch) * math.cos(yaw), math.cos(pitch) * math.sin(yaw), -math.sin(pitch))
    r0 = (math.sin(yaw), -math.cos(yaw), 0.0)
    d0 = (fw[1] * r0[2] - fw[2] * r0[1], fw[2] * r0[0] - fw[0] * r0[2], fw[0] * r0[1] - fw[1] * r0[0])
    right = tuple(math.cos(roll) * r0[i] + math.sin(roll) * d0[i] for i in range(3))
    down = tuple(-math.sin(roll) * r0[i] + math.cos(roll) * d0[i] for i in range(3))
    return fw, right, down


def truth_boxes(rocks, pose, cam):
    fw, right, down = camera_axes(pose["yaw_rad"], pose["pitch_rad"], pose["roll_rad"])
    c = (pose["x_m"], pose["y_m"], pose["z_m"])

    def project(p):
        v = [p[i] - c[i] for i in range(3)]
        z = sum(v[i] * fw[i] for i in range(3))
        if z <= 0.05:
            return None
        return (cam["fx"] * sum(v[i] * right[i] for i in range(3)) / z + cam["cx"],
                cam["fy"] * sum(v[i] * down[i] for i in range(3)) / z + cam["cy"])

    out = []
    for t in rocks:
        if math.hypot(t["x_m"] - c[0], t["y_m"] - c[1]) > 6.0:
            continue
        a, b, yaw = t["major_axis_m"] / 2, t["minor_axis_m"] / 2, math.radians(t["yaw_deg"])
        pts = [(t["x_m"], t["y_m"], t["top_z_m"])]
        for scale, zf in ((1.0, 0.0), (0.8, 0.6), (0.4, 0.95)):
            for k in range(16):
                th = 2 * math.pi * k / 16
                ex, ey = scale * a * math.cos(th), scale * b * math.sin(th)
                pts.append((t["x_m"] + ex * math.cos(yaw) - ey * math.sin(yaw),
                            t["y_m"] + ex * math.sin(yaw) + ey * math.cos(yaw),
                            t["ground_z_m"] + zf * t["height_above_ground_m"]))
        uv = [project(p) for p in pts]
        if any(q is None for q in uv):
            continue
        box = (min(q[0] for q in uv), min(q[1] for q in uv), max(q[0] for q in uv), max(q[1] for q in uv))
        if box[2] < 0 or box[3] < 0 or box[0] > cam["width"] - 1 or box[1] > cam["height"] - 1:
            continue
        out.append((box, t))
    return out


def iou(box, tbox):
    ix = max(0.0, min(box[2] + 1, tbox[2]) - max(box[0], tbox[0]))
    iy = max(0.0, min(box[3] + 1, tbox[3]) - max(box[1], tbox[1]))
    inter = ix * iy
    union = (box[2] - box[0] + 1) * (box[3] - box[1] + 1) + (tbox[2] - tbox[0]) * (tbox[3] - tbox[1]) - inter
    return inter / union if union > 0 else 0.0


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--drives", default=os.path.join(here, "../../../../shared/data/synthetic_dev/traverse"))
    ap.add_argument("--step", type=int, default=5)
    ap.add_argument("--regolith", default=os.path.join(here, "../../../build/release/tools/regolith"))
    ap.add_argument("--out", default="/tmp/assess_on_drive_frames")
    o = ap.parse_args()
    rows = []  # (score, best IoU, height of the best rock, reported height)
    for name in sorted(os.listdir(o.drives)):
        base = os.path.join(o.drives, name)
        if not os.path.exists(os.path.join(base, "truth_poses.csv")):
            continue
        inp = json.load(open(os.path.join(base, "input.json")))
        truth = json.load(open(os.path.join(base, "truth.json")))
        cam = inp["camera"]
        poses = {int(p["frame"]): {k: float(v) for k, v in p.items()}
                 for p in csv.DictReader(open(os.path.join(base, "truth_poses.csv")))}
        for f in sorted(poses)[::o.step]:
            p = poses[f]
            heading_az = 90.0 - math.degrees(p["yaw_rad"])  # clockwise from north, as the sun's azimuth
            scene = {"image": "frame", "projection": "perspective",
                     "camera": {k: cam[k] for k in ("width", "height", "fx", "fy", "cx", "cy")},
                     "sun_elevation_deg": inp["sun"]["elevation_deg"],
                     "sun_azimuth_deg": (inp["sun"]["azimuth_deg"] - heading_az) % 360.0}
            scene["camera"].update({"h_m": p["z_m"] - p["rover_z_m"], "pitch_deg": math.degrees(p["pitch_rad"]),
                                    "roll_deg": math.degrees(p["roll_rad"])})
            out = os.path.join(o.out, "%s_%04d" % (name, f))
            os.makedirs(o.out, exist_ok=True)
            scene_file = out + ".scene.json"
            json.dump(scene, open(scene_file, "w"))
            image = os.path.join(base, "frames", "%04d.png" % f)
            run = subprocess.run([o.regolith, "assess", image, "--scene", scene_file, "--out", out,
                                  "--min-rock-score", "0"], capture_output=True, text=True)
            if run.returncode:
                sys.exit("%s: assess failed: %s" % (image, run.stderr.strip()))
            summary = json.load(open(os.path.join(out, "summary.json")))
            boxes = truth_boxes(truth["rocks"], p, cam)
            for rock in summary["rocks"]:
                best, height = 0.0, 0.0
                for tbox, t in boxes:
                    v = iou(rock["box_px"], tbox)
                    if v > best:
                        best, height = v, t["height_above_ground_m"]
                rows.append((rock["score"], best, height, rock["height_m"]))
    print("floor  kept  on a rock  (>= 10 cm)  on none")
    for floor in (0.0, 0.1, 0.2, 0.3, 0.35, 0.4, 0.5, 0.6, 0.8):
        kept = [r for r in rows if r[0] >= floor]
        hit = [r for r in kept if r[1] > 0.2]
        print("%5.2f %5d %10d %11d %8d" % (floor, len(kept), len(hit), sum(1 for r in hit if r[2] >= 0.1),
                                          len(kept) - len(hit)))
    # Height of the boxes on a rock >= 5 cm at the default floor (|reported - true| / true).
    errors = sorted(abs(r[3] / r[2] - 1) for r in rows if r[0] >= 0.35 and r[1] > 0.2 and r[2] >= 0.05)
    if errors:
        print("boxes on rocks >= 5 cm (floor 0.35): %d, median height error %.0f %%"
              % (len(errors), 100 * errors[len(errors) // 2]))


if __name__ == "__main__":
    main()
