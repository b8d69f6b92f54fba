"""Dumps what the format owners' readers read from the logs of a folder, for
tests/logs_corpus.rs: per file `<out>/<file>.json` with the message count of every topic and
message type, and the stamps and values of the IMU topics imunoise reads.

- PX4 ULog (.ulg) with pyulog: topic `name` for instance 0, `name[k]` for instance k > 0;
  `sensor_combined` (timestamp, gyro_rad[0..3], accelerometer_m_s2[0..3]), `sensor_gyro`
  and `sensor_accel` (timestamp_sample, x, y, z).
- ArduPilot DataFlash (.bin) with pymavlink's DFReader: counts per message type (FMT
  excluded); IMU messages per instance: the `I` field, else `IMU` = 0, `IMU2` = 1, `IMU3` = 2,
  topic `IMU[k]` with TimeUS, GyrX..Z, AccX..Z.

Stamps are in µs as logged; values are the readers' Python floats (exact float32 values),
written in their shortest round-trip form.

Usage: python logs_corpus_dump.py DATA_DIR OUT_DIR
"""
import json
import os
import sys


def ulog(path):
    from pyulog import ULog

    u = ULog(path)
    counts, imu = {}, {}
    for d in u.data_list:
        topic = d.name if d.multi_id == 0 else "%s[%d]" % (d.name, d.multi_id)
        n = len(d.data["timestamp"])
        counts[topic] = counts.get(topic, 0) + n
        if d.name == "sensor_combined":
            stamp = "timestamp"
            fields = ["gyro_rad[%d]" % k for k in range(3)] + [
                "accelerometer_m_s2[%d]" % k for k in range(3)
            ]
        elif d.name in ("sensor_gyro", "sensor_accel"):
            stamp = "timestamp_sample" if "timestamp_sample" in d.data else "timestamp"
            fields = ["x", "y", "z"]
        else:
            continue
        t = imu.setdefault(topic, {"stamps_us": [], "columns": [[] for _ in fields]})
        t["stamps_us"] += [int(v) for v in d.data[stamp]]
        for c, f in zip(t["columns"], fields):
            c += [float(v) for v in d.data[f]]
    return {"counts": counts, "by_type": None, "imu": imu, "corrupt": bool(u.file_corruption)}


def dataflash(path):
    from pymavlink import DFReader

    r = DFReader.DFReader_binary(path, zero_time_base=False)
    by_type, imu = {}, {}
    fields = ["GyrX", "GyrY", "GyrZ", "AccX", "AccY", "AccZ"]
    while True:
        m = r.recv_msg()
        if m is None:
            break
        ty = m.get_type()
        if ty == "FMT":
            continue
        by_type[ty] = by_type.get(ty, 0) + 1
        names = m.get_fieldnames()
        if not ty.startswith("IMU") or not all(f in names for f in ["TimeUS"] + fields):
            continue
        if "I" in names:
            topic = "%s[%d]" % (ty, m.I)
        elif ty == "IMU":
            topic = "IMU[0]"
        elif len(ty) == 4 and ty[3].isdigit() and int(ty[3]) >= 2:
            topic = "IMU[%d]" % (int(ty[3]) - 1)
        else:
            continue
        t = imu.setdefault(topic, {"stamps_us": [], "columns": [[] for _ in fields]})
        t["stamps_us"].append(int(m.TimeUS))
        for c, f in zip(t["columns"], fields):
            c.append(float(getattr(m, f)))
    return {"counts": None, "by_type": by_type, "imu": imu, "corrupt": False}


def main():
    data, out = sys.argv[1], sys.argv[2]
    os.makedirs(out, exist_ok=True)
    for name in sorted(os.listdir(data)):
        ext = name.rsplit(".", 1)[-1].lower()
        if ext == "ulg":
            res = ulog(os.path.join(data, name))
        elif ext == "bin":
            res = dataflash(os.path.join(data, name))
        else:
            continue
        with open(os.path.join(out, name + ".json"), "w") as f:
            json.dump(res, f)
        print("logs_corpus_dump: %s" % name)


if __name__ == "__main__":
    main()
