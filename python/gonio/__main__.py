"""python3 -m gonio: a small command line for scripts, on the same calls as the package.

Exit codes are gonioctl's (daemon/README.md): 0 ok; 1 other server error; 2 usage error or
invalid params; 3 cannot connect or connection lost; 4 unauthorized or forbidden; 5 not
found; 6 invalid state or instrument busy; 7 instrument fault or limit violation; 8 plan
rejected; 9 a waited scan ended other than completed.
"""
from __future__ import annotations

import argparse
import json
import sys

from . import errors
from .client import Client, default_state_dir

_EXIT_BY_NAME = {"ParseError": 2, "InvalidRequest": 2, "MethodNotFound": 2, "InvalidParams": 2,
                 "InternalError": 70, "Unauthorized": 4, "Forbidden": 4, "NotFound": 5,
                 "InvalidState": 6, "InstrumentBusy": 6, "InstrumentFault": 7,
                 "LimitViolation": 7, "PlanRejected": 8}


def exit_code(e: BaseException) -> int:
    if isinstance(e, errors.ScanNotCompleted):
        return 9
    if isinstance(e, errors.RpcError):
        return _EXIT_BY_NAME.get(type(e).__name__, 1)
    if isinstance(e, ValueError):
        return 2
    if isinstance(e, TimeoutError) and not isinstance(e, errors.RequestTimeout):
        return 1  # wait --wait-timeout passed
    if isinstance(e, (errors.ConnectionLost, errors.RequestTimeout, OSError)):
        return 3
    return 1


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python3 -m gonio", description="goniod from scripts: status, "
                                "submit, wait, export (the gonio Python client's calls)")
    p.add_argument("--connect", metavar="URL", help="unix:PATH, tcp://HOST:PORT or http://HOST:PORT "
                   "(default: the state dir's socket)")
    p.add_argument("--state-dir", default=None, help=f"goniod's state dir (default {default_state_dir()})")
    p.add_argument("--token", help="bearer token (TCP, HTTP)")
    p.add_argument("--token-file", help="file holding the bearer token")
    p.add_argument("--timeout", type=float, default=30.0, help="seconds to wait for an answer")
    p.add_argument("--json", action="store_true", help="print JSON results")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    sub.add_parser("status", help="goniod, the instrument and the queue")
    s = sub.add_parser("submit", help="submit a scan; prints its id")
    s.add_argument("--sample", required=True, help="sample id or name")
    s.add_argument("--grid", action="append", default=[], help="a geometry grid, e.g. 'in=45;out=-30:80:2'")
    s.add_argument("--geometry", action="append", default=[], help="a geometry, e.g. 45as15")
    s.add_argument("--wavelengths", help="e.g. 400:700:10")
    s.add_argument("--repeats", type=int)
    s.add_argument("--name", help="label")
    s.add_argument("--wait", action="store_true", help="then wait for it to end")
    w = sub.add_parser("wait", help="wait for a scan to end, with a progress bar on a terminal")
    w.add_argument("scan", type=int)
    w.add_argument("--wait-timeout", type=float, help="seconds (default: no limit)")
    e = sub.add_parser("export", help="write a scan as a file")
    e.add_argument("scan", type=int)
    e.add_argument("--format", default="csv", choices=["csv", "json", "bsdf", "ssdd"])
    e.add_argument("--output", help="file (default: goniod's name for it; '-': standard output)")
    return p


def _status(client: Client, as_json: bool) -> None:
    info, inst, queue = client.system.info(), client.instrument.status(), client.queue.status()
    if as_json:
        print(json.dumps({"system": info, "instrument": inst, "queue": queue}, indent=2))
        return
    print(f"goniod {info.get('version', '?')} at {client.url} as {client.principal.get('name')} "
          f"({client.principal.get('role')})")
    print(f"instrument: {inst.get('state', '?')}")
    running = queue.get("running")
    running = running.get("id") if isinstance(running, dict) else running
    print(f"queue: running {'scan ' + str(running) if running else 'none'}, "
          f"{len(queue.get('waiting') or [])} waiting")


def run(args) -> int:
    client = Client(args.connect, token=args.token, token_file=args.token_file,
                    state_dir=args.state_dir, timeout=args.timeout)
    with client:
        if args.command == "status":
            _status(client, args.json)
        elif args.command == "submit":
            plan = {"sample": int(args.sample) if args.sample.isdigit() else args.sample}
            for key, value in (("grids", args.grid), ("geometries", args.geometry),
                               ("wavelengths", args.wavelengths), ("repeats", args.repeats),
                               ("name", args.name)):
                if value:
                    plan[key] = value
            scan = client.scan.submit(**plan)
            print(json.dumps(scan, indent=2) if args.json else scan["id"])
            if args.wait:
                client.scan.wait(scan=scan["id"])
        elif args.command == "wait":
            sc = client.scan.wait(scan=args.scan, timeout=args.wait_timeout)
            print(json.dumps(sc, indent=2) if args.json else f"scan {sc['id']} {sc['state']}")
        elif args.command == "export":
            ex = client.scan.export(scan=args.scan, format=args.format)
            if args.output == "-":
                sys.stdout.write(ex.content)
            else:
                print(ex.save(args.output))
    return 0


def main(argv=None) -> int:
    args = _parser().parse_args(argv)
    try:
        return run(args)
    except (errors.GonioError, OSError, ValueError) as e:
        print(f"gonio: {e}", file=sys.stderr)
        return exit_code(e)


if __name__ == "__main__":
    sys.exit(main())
