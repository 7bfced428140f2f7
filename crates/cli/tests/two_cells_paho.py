"""paho-mqtt (a third-party MQTT client) watches what the two cells publish.

    two_cells_paho.py PORT SECONDS [TOPIC...]

Subscribes to control/# and plant/# on 127.0.0.1:PORT, reconnecting when the broker goes
away, and prints one JSON object: every topic with the values it saw, in order, repeats
removed. It watches for SECONDS, or, given TOPICs, until each of them has shown both 0 and 1
(SECONDS then only bounds a run that never sees them).
"""

import json
import sys
import time

import paho.mqtt.client as mqtt

port, seconds = int(sys.argv[1]), float(sys.argv[2])
wanted = sys.argv[3:]
seen = {}


def on_connect(client, userdata, flags, reason_code, properties):
    client.subscribe([("control/#", 1), ("plant/#", 1)])


def on_message(client, userdata, msg):
    values = seen.setdefault(msg.topic, [])
    value = msg.payload.decode()
    if not values or values[-1] != value:
        values.append(value)


client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id="paho-watcher")
client.on_connect = on_connect
client.on_message = on_message
client.reconnect_delay_set(min_delay=0.1, max_delay=0.5)
client.connect("127.0.0.1", port)
client.loop_start()
deadline = time.monotonic() + seconds
while time.monotonic() < deadline:
    if wanted and all({"0", "1"} <= set(seen.get(t, [])) for t in wanted):
        break
    time.sleep(0.05)
client.loop_stop()
print(json.dumps(seen, sort_keys=True))
