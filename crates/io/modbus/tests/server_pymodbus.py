"""pymodbus (pinned in scripts/test-all.sh) reads and writes every table of the modbus_server
that tests/server_third_party.rs starts, over TCP or RTU:

    server_pymodbus.py tcp HOST PORT
    server_pymodbus.py serial PATH UNIT

Prints `ok` and exits 0 when every answer is the expected one; otherwise says what differs and
exits 1. The Rust test then checks that the writes reached the points.
"""

import sys

from pymodbus.client import ModbusSerialClient, ModbusTcpClient

failures = []


def check(what, got, want):
    if got != want:
        failures.append(f"{what}: got {got!r}, want {want!r}")


def ok(what, response):
    if response.isError():
        failures.append(f"{what}: exception {response}")
        return None
    return response


def exception(what, response, code):
    got = getattr(response, "exception_code", None) if response.isError() else "no exception"
    check(what, got, code)


def main():
    if sys.argv[1] == "tcp":
        client = ModbusTcpClient(sys.argv[2], port=int(sys.argv[3]), timeout=5, retries=0)
        unit = 1
    else:
        client = ModbusSerialClient(
            # 8N1: pseudo-terminals keep no parity setting, and pyserial fails setting one.
            sys.argv[2], baudrate=19200, bytesize=8, parity="N", stopbits=1, timeout=5, retries=0
        )
        unit = int(sys.argv[3])
    if not client.connect():
        print("cannot connect", file=sys.stderr)
        return 1
    dt = client.DATATYPE
    u = {"device_id": unit}

    # Reads of every table (values the probe module sets).
    r = ok("read coils", client.read_coils(0, count=3, **u))
    if r:
        check("coils 0-2", r.bits[:3], [False, False, True])
    r = ok("read discrete inputs", client.read_discrete_inputs(0, count=2, **u))
    if r:
        check("discrete inputs 0-1", r.bits[:2], [True, False])
    r = ok("read holding", client.read_holding_registers(8, count=1, **u))
    if r:
        check("holding 8", r.registers, [77])
    r = ok("read input", client.read_input_registers(0, count=5, **u))
    if r:
        check("input 0", r.registers[0], 4660)
        check("input 1-2 f32 high first", client.convert_from_registers(r.registers[1:3], dt.FLOAT32, word_order="big"), 1.5)
        check("input 3-4 i32 low first", client.convert_from_registers(r.registers[3:5], dt.INT32, word_order="little"), -2)

    # Writes of every kind, read back at once.
    ok("write coil", client.write_coil(0, True, **u))
    ok("write coils", client.write_coils(0, [True, True], **u))
    r = ok("read coils back", client.read_coils(0, count=2, **u))
    if r:
        check("coils 0-1 after writes", r.bits[:2], [True, True])
    ok("write register", client.write_register(0, 1234, **u))
    ok("write register i16", client.write_register(1, 65535, **u))
    ok("write u32", client.write_registers(2, client.convert_to_registers(70000, dt.UINT32, word_order="big"), **u))
    ok("write f32", client.write_registers(4, client.convert_to_registers(2.5, dt.FLOAT32, word_order="big"), **u))
    ok("write f32 low first", client.write_registers(6, client.convert_to_registers(-0.5, dt.FLOAT32, word_order="little"), **u))
    r = ok("read/write", client.readwrite_registers(read_address=0, read_count=9, write_address=0, values=[4321], **u))
    if r:
        check("read/write sees its write", r.registers[0], 4321)
        check("i16", r.registers[1], 65535)
        check("u32", client.convert_from_registers(r.registers[2:4], dt.UINT32, word_order="big"), 70000)
        check("f32", client.convert_from_registers(r.registers[4:6], dt.FLOAT32, word_order="big"), 2.5)
        check("f32 low first", client.convert_from_registers(r.registers[6:8], dt.FLOAT32, word_order="little"), -0.5)
        check("read-only", r.registers[8], 77)

    # Exceptions.
    exception("write a point of another module", client.write_register(8, 1, **u), 2)
    exception("write another module's coil", client.write_coil(2, False, **u), 2)
    exception("read unmapped", client.read_holding_registers(9, count=1, **u), 2)
    exception("write half of a u32", client.write_register(2, 1, **u), 2)
    client.close()

    if failures:
        for f in failures:
            print(f, file=sys.stderr)
        return 1
    print("ok")
    return 0


if __name__ == "__main__":
    sys.exit(main())
