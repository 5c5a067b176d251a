#!/usr/bin/python3
"""A DEM adapter server in Python: the demfem protocol v1 (docs/protocol.md) served with Debian's
python3-zmq and python3-numpy. It is the 'harmonic' analytic test backend of demfem
(adapter/test_backends.hpp) written again from the protocol document, to show that a DEM code in
another language can be coupled to demfem-fem without any demfem code.

    /usr/bin/python3 harmonic_server.py --study studies/quick.json --bind tcp://127.0.0.1:5555
    demfem-fem run studies/quick.json --connect tcp://127.0.0.1:5555

Replace HarmonicDem by your DEM code: the four calls are node_positions, node_forces,
set_node_positions and simulate.
"""
import argparse
import json
import math
import os
import sys

import numpy as np
import zmq

PROTOCOL_VERSION = 1
# Error codes (docs/protocol.md)
BAD_REQUEST, UNKNOWN_GEOMETRY, SIZE_MISMATCH, VERSION_MISMATCH, UNSUPPORTED = 1, 2, 3, 4, 8


class ProtocolError(Exception):
    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


def plate_surface(length, width, thickness, spacing):
    """Surface nodes of the plate's keypoint grid (tool frame, m) and outward triangles."""
    n = [max(1, round(e / spacing)) + 1 for e in (width, length, thickness)]
    extent = (width, length, thickness)
    offset = (-width / 2, 0.0, -thickness / 2)
    ids, nodes = {}, []
    for k in range(n[2]):
        for j in range(n[1]):
            for i in range(n[0]):
                if i in (0, n[0] - 1) or j in (0, n[1] - 1) or k in (0, n[2] - 1):
                    ids[(i, j, k)] = len(nodes)
                    nodes.append([offset[c] + extent[c] * (i, j, k)[c] / (n[c] - 1) for c in range(3)])
    nodes = np.array(nodes)
    centre = nodes.mean(axis=0)
    triangles = []
    for axis in range(3):  # the two faces normal to each axis
        a, b = [c for c in range(3) if c != axis]
        for side in (0, n[axis] - 1):
            for u in range(n[a] - 1):
                for v in range(n[b] - 1):
                    def node(du, dv):
                        g = [0, 0, 0]
                        g[axis], g[a], g[b] = side, u + du, v + dv
                        return ids[tuple(g)]
                    for tri in ((node(0, 0), node(1, 0), node(1, 1)), (node(0, 0), node(1, 1), node(0, 1))):
                        p = nodes[list(tri)]
                        normal = np.cross(p[1] - p[0], p[2] - p[0])
                        if np.dot(normal, p.mean(axis=0) - centre) < 0:
                            tri = (tri[0], tri[2], tri[1])
                        triangles.append(tri)
    return nodes, np.array(triangles, dtype="<i4")


class HarmonicDem:
    """f_z = F/n_tip (1 + x/W) sin(2 pi f t) on the tip row (y = 0); interval means exact."""

    def __init__(self, name, length, width, thickness, spacing, force, frequency, dt):
        self.name, self.width, self.force, self.omega, self.dt = name, width, force, 2 * math.pi * frequency, dt
        self.undeformed, self.triangles = plate_surface(length, width, thickness, spacing)
        self.current = self.undeformed.copy()
        self.tip = np.nonzero(self.undeformed[:, 1] <= 0.5 * spacing)[0]
        self.step = self.start_step = 0
        self.motion = np.zeros(7)

    def time(self):
        return self.step * self.dt

    def node_positions(self):
        return self.current

    def node_forces(self, instantaneous):
        t1, t0 = self.step * self.dt, self.start_step * self.dt
        if instantaneous or self.step == self.start_step:
            factor = math.sin(self.omega * t1)
        else:
            half = 0.5 * (t1 - t0)
            factor = math.sin(self.omega * (t0 + half)) * math.sin(self.omega * half) / (self.omega * half)
        forces = np.zeros_like(self.undeformed)
        per_node = self.force / len(self.tip)
        forces[self.tip, 2] = per_node * (1.0 + self.undeformed[self.tip, 0] / self.width) * factor
        return forces

    def set_node_positions(self, xyz):
        if xyz.shape != self.undeformed.shape:
            raise ProtocolError(SIZE_MISMATCH, f"expected {len(self.undeformed)} nodes, got {len(xyz)}")
        self.current = xyz

    def simulate(self, duration):
        self.start_step = self.step
        self.step += round(duration / self.dt)


def floats(frame, count, what):
    if len(frame) != 8 * count:
        raise ProtocolError(BAD_REQUEST, f"{what}: {len(frame)} bytes, expected {8 * count}")
    values = np.frombuffer(frame, dtype="<f8")
    if not np.all(np.isfinite(values)):
        raise ProtocolError(BAD_REQUEST, f"{what}: non-finite value")
    return values


def handle(dem, frames, session):
    """One request (list of byte frames) -> reply frames. Raises ProtocolError."""
    try:
        header = json.loads(frames[0])
    except (ValueError, UnicodeDecodeError):
        raise ProtocolError(BAD_REQUEST, "frame 0 is not valid JSON")
    if not isinstance(header, dict):
        raise ProtocolError(BAD_REQUEST, "frame 0 must be a JSON object")
    if header.get("v") != PROTOCOL_VERSION:
        raise ProtocolError(VERSION_MISMATCH, f"protocol version {header.get('v')!r} not supported")
    op = header.get("op")
    reply = {"v": PROTOCOL_VERSION, "op": op, "seq": header.get("seq")}
    arrays = []

    def geometry():
        if header.get("geometry") != dem.name:
            raise ProtocolError(UNKNOWN_GEOMETRY, f"unknown geometry {header.get('geometry')!r}")

    if op == "hello":
        if header.get("protocol_version") != PROTOCOL_VERSION:
            raise ProtocolError(VERSION_MISMATCH, "this server speaks protocol version 1")
        session["hello"] = True
        reply.update(protocol_version=PROTOCOL_VERSION, backend="python-harmonic", backend_version="1",
                     dem_time_step_s=dem.dt)
    elif not session["hello"]:
        raise ProtocolError(BAD_REQUEST, "the first request of a session must be 'hello'")
    elif op == "list_geometries":
        reply["geometries"] = [{"name": dem.name, "node_count": len(dem.undeformed),
                                "triangle_count": len(dem.triangles)}]
        arrays.append(dem.triangles.tobytes())
    elif op == "get_time":
        reply["time_s"] = dem.time()
    elif op in ("get_node_positions", "get_node_forces"):
        geometry()
        if op == "get_node_positions":
            values = dem.node_positions()
        else:
            if header.get("mode") not in ("interval_mean", "instantaneous"):
                raise ProtocolError(BAD_REQUEST, "header field 'mode' must be interval_mean or instantaneous")
            values = dem.node_forces(header["mode"] == "instantaneous")
        reply.update(geometry=dem.name, n=len(values))
        arrays.append(np.ascontiguousarray(values, dtype="<f8").tobytes())
    elif op == "set_node_positions":
        geometry()
        n = header.get("n")
        if not isinstance(n, int) or n < 0 or len(frames) != 2:
            raise ProtocolError(BAD_REQUEST, "set_node_positions needs 'n' and one float64 frame")
        dem.set_node_positions(floats(frames[1], 3 * n, "xyz").reshape(n, 3).copy())
    elif op == "simulate":
        d = header.get("duration_s")
        if not isinstance(d, (int, float)) or isinstance(d, bool) or not d >= 0:
            raise ProtocolError(BAD_REQUEST, "header field 'duration_s' must be a number >= 0")
        dem.simulate(d)
        reply["time_s"] = dem.time()
    elif op == "get_rigid_motion":
        geometry()
        arrays.append(dem.motion.astype("<f8").tobytes())
    elif op == "set_rigid_motion":
        geometry()
        if len(frames) != 2:
            raise ProtocolError(BAD_REQUEST, "set_rigid_motion needs one float64 frame of 7 values")
        dem.motion = floats(frames[1], 7, "rigid motion").copy()
    elif op in ("checkpoint", "restore"):
        raise ProtocolError(UNSUPPORTED, "this example server does not checkpoint")
    elif op == "shutdown":
        session["shutdown"] = True
    else:
        raise ProtocolError(BAD_REQUEST, f"unknown operation {op!r}")
    return [json.dumps(reply).encode()] + arrays


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--study", required=True, help="demfem study file: the first tool's plate geometry is served")
    parser.add_argument("--bind", default="tcp://127.0.0.1:5555", help="endpoint; tcp port * picks a free one")
    parser.add_argument("--endpoint-file", help="write the bound endpoint here")
    parser.add_argument("--force-N", type=float, default=-10.0)
    parser.add_argument("--frequency-Hz", type=float, default=20.0)
    parser.add_argument("--dt-s", type=float, default=1e-5)
    parser.add_argument("--idle-timeout-s", type=float, default=60.0)
    args = parser.parse_args()

    with open(args.study) as f:
        tool = json.load(f)["tools"][0]
    g = tool["geometry"]
    dem = HarmonicDem(tool.get("name", "tool"), g["length_mm"] / 1e3, g["width_mm"] / 1e3, g["thickness_mm"] / 1e3,
                      g["keypoint_spacing_mm"] / 1e3, args.force_N, args.frequency_Hz, args.dt_s)

    socket = zmq.Context.instance().socket(zmq.REP)
    socket.setsockopt(zmq.LINGER, 0)
    socket.bind(args.bind)
    endpoint = socket.getsockopt_string(zmq.LAST_ENDPOINT)
    if args.endpoint_file:
        with open(args.endpoint_file + ".partial", "w") as f:
            f.write(endpoint + "\n")
        os.rename(args.endpoint_file + ".partial", args.endpoint_file)
    print(f"harmonic_server.py: serving on {endpoint}", flush=True)

    session = {"hello": False, "shutdown": False}
    while not session["shutdown"]:
        if not socket.poll(int(args.idle_timeout_s * 1000)):
            sys.exit(f"harmonic_server.py: no request within {args.idle_timeout_s} s, giving up")
        frames = socket.recv_multipart()
        try:
            reply = handle(dem, frames, session)
        except ProtocolError as e:
            header = {}
            try:
                header = json.loads(frames[0]) if frames else {}
            except (ValueError, UnicodeDecodeError):
                pass
            seq = header.get("seq", 0) if isinstance(header, dict) else 0
            op = header.get("op", "error") if isinstance(header, dict) else "error"
            reply = [json.dumps({"v": PROTOCOL_VERSION, "op": op, "seq": seq,
                                 "error": {"code": e.code, "message": str(e)}}).encode()]
        socket.send_multipart(reply)


if __name__ == "__main__":
    main()
