#!/usr/bin/env python3
"""The ROS 2 interface package msgs/ros2/regolith_msgs must describe exactly the wire types of
msgs/idl/regolith_msgs: same messages, same fields in the same order with the same types; every
.msg listed in its CMakeLists.txt, every package it uses declared in package.xml.
With --definitions, checks msgs/ros2/definitions/<pkg>/msg/<Type>.msg (the ROS 2 Humble
definitions of every other wire type, used for the MCAP ros2msg schemas) the same way: every IDL
struct outside regolith_msgs has exactly one .msg with the same fields, order and types (IDL
fixed arrays `double covariance[36]` are `float64[36] covariance`; a type without a package is
resolved in the message's own package; constants are skipped: they are not on the wire), and every
type a .msg uses exists.
Usage: check_ros2_package.py SOURCE_DIR [--definitions]. Exit 1 with one line per difference."""
import pathlib
import re
import sys

IDL_TYPES = {"double": "float64", "float": "float32", "boolean": "bool", "octet": "byte", "string": "string",
             "int8": "int8", "uint8": "uint8", "int16": "int16", "uint16": "uint16", "int32": "int32",
             "uint32": "uint32", "int64": "int64", "uint64": "uint64"}


def idl_type(t):
    t = t.strip()
    m = re.fullmatch(r"sequence<(.+),\s*(\d+)\s*>", t)
    if m:  # bounded sequence: sequence<uint8, 64> -> uint8[<=64]
        return idl_type(m.group(1)) + f"[<={m.group(2)}]"
    m = re.fullmatch(r"sequence<(.+)>", t)
    if m:
        return idl_type(m.group(1)) + "[]"
    m = re.fullmatch(r"(\w+)::msg::dds_::(\w+)_", t)
    if m:
        return f"{m.group(1)}/{m.group(2)}"
    if t in IDL_TYPES:
        return IDL_TYPES[t]
    m = re.fullmatch(r"string\s*<\s*(\d+)\s*>", t)
    if m:  # bounded string: string<256> -> string<=256
        return f"string<={m.group(1)}"
    raise ValueError(f"unknown IDL type {t!r}")


def idl_fields(path):
    text = re.sub(r"//[^\n]*", "", path.read_text())
    body = re.search(r"struct\s+\w+_\s*\{(.*?)\};", text, re.S)
    fields = []
    for decl in body.group(1).split(";"):
        decl = " ".join(decl.split())
        if not decl:
            continue
        t, name = decl.rsplit(" ", 1)
        t = idl_type(t)
        m = re.fullmatch(r"(\w+)\s*\[\s*(\d+)\s*\]", name)
        if m:  # fixed array: double covariance[36] -> float64[36] covariance
            name, t = m.group(1), f"{t}[{m.group(2)}]"
        fields.append((t, name))
    return fields


PRIMITIVES = set(IDL_TYPES.values()) | {"char", "wstring"}


def msg_fields(path, pkg=None):
    """(type, name) per field of a .msg; constants (`byte OK=0`) skipped; with `pkg`, a complex
    type without a package (`KeyValue[]`) is resolved in that package."""
    fields = []
    for line in path.read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        t, name = line.split()[:2]
        if "=" in name or (len(line.split()) > 2 and line.split()[2].startswith("=")):
            continue  # constant
        base = re.sub(r"\[(<=)?\d*\]$", "", t)
        if pkg and "/" not in base and base not in PRIMITIVES and not re.fullmatch(r"w?string<=\d+", base):
            t = f"{pkg}/{t}"
        fields.append((t, name))
    return fields


def check_definitions(src):
    """msgs/ros2/definitions against every IDL package except regolith_msgs."""
    src = pathlib.Path(src)
    errors = []
    idl = {}
    for p in sorted((src / "msgs/idl").glob("*/msg/*.idl")):
        pkg = p.parent.parent.name
        if pkg != "regolith_msgs":
            idl[f"{pkg}/{p.stem}"] = idl_fields(p)
    msg = {}
    for p in sorted((src / "msgs/ros2/definitions").glob("*/msg/*.msg")):
        pkg = p.parent.parent.name
        msg[f"{pkg}/{p.stem}"] = msg_fields(p, pkg)
    for name in sorted(set(idl) - set(msg)):
        errors.append(f"{name}: IDL type without a .msg in msgs/ros2/definitions")
    for name in sorted(set(msg) - set(idl)):
        errors.append(f"{name}: .msg without an IDL type in msgs/idl")
    for name in sorted(set(idl) & set(msg)):
        if idl[name] != msg[name]:
            errors.append(f"{name}: IDL fields {idl[name]} != .msg fields {msg[name]}")
    known = set(msg) | {f"regolith_msgs/{p.stem}" for p in (src / "msgs/ros2/regolith_msgs/msg").glob("*.msg")}
    for name, fields in sorted(msg.items()):
        for t, field in fields:
            base = re.sub(r"\[\d*\]$", "", t)
            if "/" in base and base not in known:
                errors.append(f"{name}.{field}: type {base} has no definition")
    for e in errors:
        print(e)
    print(f"{len(msg)} definitions checked against {len(idl)} IDL types, {len(errors)} differences")
    return 1 if errors else 0


def main(src):
    src = pathlib.Path(src)
    idl_dir = src / "msgs/idl/regolith_msgs/msg"
    pkg = src / "msgs/ros2/regolith_msgs"
    errors = []
    idl = {p.stem: idl_fields(p) for p in sorted(idl_dir.glob("*.idl"))}
    msg = {p.stem: msg_fields(p) for p in sorted((pkg / "msg").glob("*.msg"))}
    if sorted(idl) != sorted(msg):
        errors.append(f"messages differ: IDL {sorted(idl)} vs .msg {sorted(msg)}")
    for name in sorted(set(idl) & set(msg)):
        if idl[name] != msg[name]:
            errors.append(f"{name}: IDL fields {idl[name]} != .msg fields {msg[name]}")
    cmake = (pkg / "CMakeLists.txt").read_text()
    xml = (pkg / "package.xml").read_text()
    for name in sorted(msg):
        if f'"msg/{name}.msg"' not in cmake:
            errors.append(f"CMakeLists.txt does not generate msg/{name}.msg")
    used = {t.split("/")[0] for fields in msg.values() for t, _ in fields if "/" in t}
    for dep in sorted(used):
        if f"<depend>{dep}</depend>" not in xml:
            errors.append(f"package.xml lacks <depend>{dep}</depend>")
        if dep not in cmake:
            errors.append(f"CMakeLists.txt lacks the dependency {dep}")
    for e in errors:
        print(e)
    print(f"{len(msg)} messages checked, {len(errors)} differences")
    return 1 if errors else 0


if __name__ == "__main__":
    args = [a for a in sys.argv[1:] if a != "--definitions"]
    src_dir = args[0] if args else "."
    sys.exit(check_definitions(src_dir) if "--definitions" in sys.argv[1:] else main(src_dir))
