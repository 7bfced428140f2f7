"""A minimal Sparkplug B host for tests/sparkplug.rs: paho-mqtt subscribes to spBv1.0/GROUP/#
and every payload is decoded by a third-party implementation, pysparkplug (its protobuf
classes are compiled from Eclipse Tahu's sparkplug_b.proto, run by Google's protobuf
runtime), and checked against the specification's rules for an edge node:

- NBIRTH: seq 0, a bdSeq metric (UInt64), `Node Control/Rebirth` (Boolean, false), every
  metric with a name, an alias and a datatype; aliases unique;
- NDATA: seq one more than the last message's (mod 256), metrics by alias only (no names),
  every alias born in the last NBIRTH, values decoded with the NBIRTH's datatypes;
- NDEATH: a bdSeq equal to that of the last NBIRTH;
- every payload with a timestamp.

One JSON line per message on stdout ({"type": "NBIRTH", ...}); a broken rule is a line
{"type": "error", "why": ...}. Commands on stdin: `rebirth` (publish an NCMD with
Node Control/Rebirth = true, encoded by pysparkplug), `quit`.

usage: python sparkplug_host.py PORT GROUP EDGE_NODE
"""

import json
import sys
import threading

import paho.mqtt.client as mqtt
import pysparkplug as spb
from pysparkplug import _protobuf as pb

port, group, node = int(sys.argv[1]), sys.argv[2], sys.argv[3]
state = {"birth": None, "pb_birth": None, "seq": None}
lock = threading.Lock()


def emit(obj):
    with lock:
        print(json.dumps(obj), flush=True)


def error(why):
    emit({"type": "error", "why": why})


def plain(v):
    return v if isinstance(v, (bool, int, float)) or v is None else str(v)


def on_message(client, userdata, msg):
    parts = msg.topic.split("/")
    if len(parts) != 4 or parts[0] != "spBv1.0" or parts[1] != group or parts[3] != node:
        error(f"unexpected topic {msg.topic}")
        return
    kind = parts[2]
    if kind == "NCMD":
        return
    raw = pb.Payload.FromString(msg.payload)
    if not raw.HasField("timestamp"):
        error(f"{kind} without a timestamp")
    if kind == "NBIRTH":
        birth = spb.NBirth.decode(msg.payload)
        if raw.seq != 0 or not raw.HasField("seq"):
            error(f"NBIRTH seq {raw.seq}")
        metrics = {}
        aliases = set()
        for m in raw.metrics:
            if not m.HasField("name") or not m.HasField("datatype"):
                error(f"NBIRTH metric without name or datatype: {m}")
            if m.name != "bdSeq":
                if not m.HasField("alias"):
                    error(f"NBIRTH metric {m.name} without an alias")
                if m.alias in aliases:
                    error(f"alias {m.alias} twice")
                aliases.add(m.alias)
        for m in birth.metrics:
            metrics[m.name] = [m.alias, int(m.datatype), plain(m.value)]
        if metrics.get("bdSeq", [None, None])[1] != int(spb.DataType.UINT64):
            error(f"NBIRTH bdSeq metric missing or not UInt64: {metrics.get('bdSeq')}")
        if metrics.get("Node Control/Rebirth") is None or metrics["Node Control/Rebirth"][1:] != [
            int(spb.DataType.BOOLEAN),
            False,
        ]:
            error(f"NBIRTH without Node Control/Rebirth false: {metrics}")
        state["birth"], state["seq"] = birth, 0
        emit({"type": "NBIRTH", "seq": raw.seq, "bdSeq": metrics["bdSeq"][2], "metrics": metrics})
    elif kind == "NDATA":
        if state["birth"] is None:
            error("NDATA before any NBIRTH")
            return
        expect = (state["seq"] + 1) % 256
        if raw.seq != expect:
            error(f"NDATA seq {raw.seq}, expected {expect}")
        state["seq"] = raw.seq
        for m in raw.metrics:
            if m.HasField("name"):
                error(f"NDATA metric with a name ({m.name}): aliases only after the NBIRTH")
        data = spb.NData.decode(msg.payload, birth=state["birth"])
        values = {}
        for m in data.metrics:
            if m.name is None:
                error(f"NDATA alias {m.alias} was not born")
                continue
            values[m.name] = plain(m.value)
        emit({"type": "NDATA", "seq": raw.seq, "values": values})
    elif kind == "NDEATH":
        death = spb.NDeath.decode(msg.payload).bd_seq_metric
        if death.name != "bdSeq" or death.datatype != spb.DataType.UINT64:
            error(f"NDEATH metric {death}: expected bdSeq, UInt64")
        emit({"type": "NDEATH", "bdSeq": death.value})
    else:
        error(f"unexpected message type {kind}")


def on_connect(client, userdata, flags, reason, properties=None):
    client.subscribe(f"spBv1.0/{group}/#", qos=1)


def on_subscribe(client, userdata, mid, reasons, properties=None):
    emit({"type": "ready"})


client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"host-{port}")
client.on_connect = on_connect
client.on_message = on_message
client.on_subscribe = on_subscribe
client.reconnect_delay_set(0.1, 0.5)
client.connect("127.0.0.1", port)
client.loop_start()

for line in sys.stdin:
    cmd = line.strip()
    if cmd == "rebirth":
        cmd_payload = spb.NCmd(
            timestamp=spb.get_current_timestamp(),
            metrics=(
                spb.Metric(
                    timestamp=spb.get_current_timestamp(),
                    name="Node Control/Rebirth",
                    datatype=spb.DataType.BOOLEAN,
                    value=True,
                ),
            ),
        )
        client.publish(f"spBv1.0/{group}/NCMD/{node}", cmd_payload.encode(include_dtypes=True), qos=0)
    elif cmd == "quit":
        break
client.loop_stop()
client.disconnect()
