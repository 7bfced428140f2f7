"""paho-mqtt (a third-party MQTT client) publishes a file of messages as fast as the broker
takes them, for crates/cli/tests/mqtt_hostile.rs.

    mqtt_flood.py PORT FILE

FILE holds records: topic length (2 bytes, big-endian), topic, flags (1 byte: bits 0-1 the
QoS, bit 2 retain, bit 3 "repeat": the payload is one byte to repeat COUNT times), payload
length or COUNT (4 bytes, big-endian), payload. Prints the number of messages sent.
"""

import struct
import sys

import paho.mqtt.client as mqtt

port, path = int(sys.argv[1]), sys.argv[2]
client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="petriplc-flood")
client.max_queued_messages_set(0)
client.connect("127.0.0.1", port)
client.loop_start()
sent = 0
pending = []
with open(path, "rb") as f:
    data = f.read()
at = 0
while at < len(data):
    (topic_len,) = struct.unpack_from(">H", data, at)
    at += 2
    topic = data[at : at + topic_len].decode()
    at += topic_len
    flags = data[at]
    (n,) = struct.unpack_from(">I", data, at + 1)
    at += 5
    if flags & 8:
        payload = data[at : at + 1] * n
        at += 1
    else:
        payload = data[at : at + n]
        at += n
    info = client.publish(topic, payload, qos=flags & 3, retain=bool(flags & 4))
    pending.append(info)
    sent += 1
    # Large ones one at a time; the rest in batches, so paho never holds many at once.
    if len(payload) > 1 << 20 or len(pending) >= 200:
        for p in pending:
            p.wait_for_publish(60)
        pending = []
for p in pending:
    p.wait_for_publish(60)
client.disconnect()
client.loop_stop()
print(sent)
