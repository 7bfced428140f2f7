"""Python asyncua (a third-party OPC UA client) against petriplc's opcua_server.

    asyncua_client.py mixer URL PLC_ID USER PASSWORD SECONDS   browse, read, subscribe, write
    asyncua_client.py secure URL PLC_ID USER PASSWORD PKI_DIR  Basic256Sha256 Sign&Encrypt

Prints one JSON object on the last line of standard output; exits 1 with a message when a
check fails.
"""

import asyncio
import json
import shutil
import sys
import time
from pathlib import Path

from asyncua import Client, ua
from asyncua.crypto.cert_gen import setup_self_signed_certificate
from asyncua.crypto.security_policies import SecurityPolicyBasic256Sha256
from cryptography.x509.oid import ExtendedKeyUsageOID

# The mixer's points: name -> (owner, OPC UA type).
MIXER = {
    "B1": ("operator", ua.VariantType.Boolean),
    "N1": ("tank", ua.VariantType.Boolean),
    "N2": ("tank", ua.VariantType.Boolean),
    "N3": ("tank", ua.VariantType.Boolean),
    "L1": ("controller", ua.VariantType.Boolean),
    "L2": ("controller", ua.VariantType.Boolean),
    "L3": ("controller", ua.VariantType.Boolean),
    "V1": ("controller", ua.VariantType.Boolean),
    "V2": ("controller", ua.VariantType.Boolean),
    "V3": ("controller", ua.VariantType.Boolean),
    "A1": ("controller", ua.VariantType.Boolean),
    "M1": ("controller", ua.VariantType.Boolean),
    "setpoint": ("opcua", ua.VariantType.UInt16),
    "stop": ("opcua", ua.VariantType.Boolean),
}


def fail(message):
    print(f"FAILED: {message}", file=sys.stderr)
    sys.exit(1)


def expect(cond, message):
    if not cond:
        fail(message)


async def expect_refused(coro, code, what):
    try:
        await coro
    except ua.UaStatusCodeError as e:
        got = ua.StatusCode(e.code).name
        expect(got == code, f"{what}: expected {code}, got {got}")
        return
    fail(f"{what}: accepted, expected {code}")


class Changes:
    """Every data change notification: (receipt time, point, value, source timestamp)."""

    def __init__(self, names):
        self.names = names
        self.seen = []

    def datachange_notification(self, node, val, data):
        now = time.time()
        dv = data.monitored_item.Value
        self.seen.append((now, self.names[node.nodeid], val, dv.SourceTimestamp.timestamp()))


async def mixer(url, plc_id, user, password, seconds):
    out = {}
    # Anonymous: read-only (anonymous = read).
    async with Client(url=url, timeout=10) as client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        objects = client.nodes.objects
        folders = {(await c.read_browse_name()).Name: c for c in await objects.get_children()}
        for module in ["operator", "tank", "controller", "opcua"]:
            expect(module in folders, f"no folder {module} below Objects: {sorted(folders)}")
        nodes = {}
        for name, (owner, vtype) in MIXER.items():
            node = await objects.get_child([f"{ns}:{owner}", f"{ns}:{name}"])
            nodes[name] = node
            bname = await node.read_browse_name()
            dname = await node.read_display_name()
            expect(bname.Name == name and bname.NamespaceIndex == ns, f"browse name {bname}")
            expect(dname.Text == name, f"display name {dname}")
            dv = await node.read_data_value()
            expect(dv.Value.VariantType == vtype, f"{name}: {dv.Value.VariantType} is not {vtype}")
            expect(dv.StatusCode.is_good(), f"{name}: status {dv.StatusCode}")
            desc = (await node.read_description()).Text
            expect(desc, f"{name} has no description")
            prop = await node.get_child([f"{ns}:Owner"])
            expect(await prop.read_value() == owner, f"{name}: Owner property")
        out["read"] = len(nodes)
        # The controller's marking and every module's status.
        marking = await objects.get_child([f"{ns}:controller", f"{ns}:Marking"])
        places = {(await p.read_browse_name()).Name: await p.read_value()
                  for p in await marking.get_children()}
        expect(len(places) >= 4, f"marking: {places}")
        out["places"] = len(places)
        state = await objects.get_child([f"{ns}:controller", f"{ns}:Status", f"{ns}:State"])
        scans = await objects.get_child([f"{ns}:controller", f"{ns}:Status", f"{ns}:Scans"])
        await asyncio.sleep(0.3)
        expect(await state.read_value() == "running", "controller not running")
        expect(await scans.read_value() > 0, "controller scans")
        # Markings are read-only for everyone, and anonymous users may not write at all.
        place = (await marking.get_children())[0]
        await expect_refused(place.write_value(ua.DataValue(ua.Variant(5, ua.VariantType.UInt64))),
                             "BadNotWritable", "writing a marking")
        await expect_refused(
            nodes["setpoint"].write_value(ua.DataValue(ua.Variant(3, ua.VariantType.UInt16))),
            "BadUserAccessDenied", "an anonymous write")

        # Subscribe at the scan period: every change of B1, N1, N2, N3.
        watched = {nodes[n].nodeid: n for n in ["B1", "N1", "N2", "N3"]}
        changes = Changes(watched)
        params = ua.CreateSubscriptionParameters(
            RequestedPublishingInterval=10, RequestedLifetimeCount=1000,
            RequestedMaxKeepAliveCount=100, MaxNotificationsPerPublish=0, Priority=0)
        sub = await client.create_subscription(params, changes)
        out["publishing_ms"] = sub.parameters.RequestedPublishingInterval
        await sub.subscribe_data_change([nodes[n] for n in watched.values()],
                                        sampling_interval=0, queuesize=100)
        started = time.time()
        # At least `seconds`, then until every point changed twice: a loaded machine (a CI
        # runner building beside the test) may run the mixer's cycle slower than planned.
        deadline = started + max(10 * seconds, 30)
        while True:
            await asyncio.sleep(0.1)
            counts = {}
            for c in changes.seen:
                if c[3] >= started - 0.001:
                    counts[c[1]] = counts.get(c[1], 0) + 1
            done = all(counts.get(n, 0) >= 2 for n in watched.values())
            if (done and time.time() - started >= seconds) or time.time() > deadline:
                break
        await sub.delete()
        seen = [c for c in changes.seen if c[3] >= started - 0.001]
        by_point = {}
        for _, name, val, _ in seen:
            by_point.setdefault(name, []).append(bool(val))
        for n in watched.values():
            expect(len(by_point.get(n, [])) >= 2, f"{n} changed fewer than twice: {by_point}")
        latency = sorted((t - src) * 1000 for t, _, _, src in seen)
        out["changes"] = {n: v for n, v in by_point.items()}
        out["latency_ms_p50"] = latency[len(latency) // 2]
        out["latency_ms_max"] = latency[-1]

    # A user may write the points the server owns, and only those.
    client = Client(url=url, timeout=10)
    client.set_user(user)
    client.set_password(password)
    async with client:
        ns = await client.get_namespace_index(f"urn:petriplc:{plc_id}")
        objects = client.nodes.objects
        setpoint = await objects.get_child([f"{ns}:opcua", f"{ns}:setpoint"])
        await setpoint.write_value(ua.DataValue(ua.Variant(1234, ua.VariantType.UInt16)))
        expect(await setpoint.read_value() == 1234, "read back the written set point")
        await expect_refused(
            setpoint.write_value(ua.DataValue(ua.Variant(70000, ua.VariantType.UInt32))),
            "BadOutOfRange", "a value that does not fit")
        await expect_refused(
            setpoint.write_value(ua.DataValue(ua.Variant("x", ua.VariantType.String))),
            "BadTypeMismatch", "a string")
        v1 = await objects.get_child([f"{ns}:controller", f"{ns}:V1"])
        await expect_refused(v1.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean))),
                             "BadNotWritable", "writing the controller's V1")
        b1 = await objects.get_child([f"{ns}:operator", f"{ns}:B1"])
        await expect_refused(b1.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean))),
                             "BadNotWritable", "writing the operator's B1")
        # The write reaches the other modules: `stop` is the shutdown module's point.
        stop = await objects.get_child([f"{ns}:opcua", f"{ns}:stop"])
        await stop.write_value(ua.DataValue(ua.Variant(True, ua.VariantType.Boolean)))
    print(json.dumps(out))


async def secure(url, plc_id, user, password, pki):
    out = {}
    work = Path(pki).parent / "client"
    work.mkdir(exist_ok=True)
    key, cert = work / "client.pem", work / "client.der"
    app_uri = "urn:petriplc-test:asyncua"
    await setup_self_signed_certificate(key, cert, app_uri, "localhost",
                                        [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "asyncua test"})

    def client_for(with_user):
        c = Client(url=url, timeout=10)
        c.application_uri = app_uri
        if with_user is not None:
            c.set_user(with_user[0])
            c.set_password(with_user[1])
        return c

    async def connect(c):
        await c.set_security(SecurityPolicyBasic256Sha256, str(cert), str(key),
                             mode=ua.MessageSecurityMode.SignAndEncrypt)
        await c.connect()
        await c.disconnect()

    # Security None is not offered.
    endpoints = await Client(url=url, timeout=10).connect_and_get_server_endpoints()
    modes = sorted({(e.SecurityPolicyUri.split("#")[-1], e.SecurityMode.name) for e in endpoints})
    expect(("None", "None_") not in modes, f"security None offered: {modes}")
    out["endpoints"] = modes
    # An unknown client certificate is refused and kept in rejected/ for the operator to trust.
    try:
        await connect(client_for((user, password)))
        fail("an untrusted client certificate was accepted")
    except Exception as e:  # noqa: BLE001 - the stack reports it in several ways
        out["untrusted"] = type(e).__name__
    rejected = list((Path(pki) / "rejected").glob("*.der"))
    expect(rejected, "the refused certificate is not in pki/rejected")
    for r in rejected:
        shutil.move(str(r), str(Path(pki) / "trusted" / r.name))
    # Trusted now: without credentials, or with a wrong password, still refused.
    for who, creds in [("no credentials", None), ("a wrong password", (user, "wrong"))]:
        try:
            await connect(client_for(creds))
            fail(f"a session with {who} was accepted")
        except ua.UaStatusCodeError as e:
            out[who] = ua.StatusCode(e.code).name
    # With the password: read and write over Sign & Encrypt.
    c = client_for((user, password))
    await c.set_security(SecurityPolicyBasic256Sha256, str(cert), str(key),
                         mode=ua.MessageSecurityMode.SignAndEncrypt)
    async with c:
        ns = await c.get_namespace_index(f"urn:petriplc:{plc_id}")
        sp = await c.nodes.objects.get_child([f"{ns}:opcua", f"{ns}:setpoint"])
        await sp.write_value(ua.DataValue(ua.Variant(77, ua.VariantType.UInt16)))
        expect(await sp.read_value() == 77, "secure write read back")
        out["secure_write"] = True
    print(json.dumps(out))


def main():
    what = sys.argv[1]
    if what == "mixer":
        asyncio.run(mixer(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], float(sys.argv[6])))
    elif what == "secure":
        asyncio.run(secure(sys.argv[2], sys.argv[3], sys.argv[4], sys.argv[5], sys.argv[6]))
    else:
        fail(f"unknown check {what}")


if __name__ == "__main__":
    main()
