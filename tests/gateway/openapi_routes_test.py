#!/usr/bin/env python3
"""docs/openapi.yaml lists exactly the REST gateway's routes: every (method, path) of the route table
in gateway/src/routes.c ({ "GET", "/jobs/{id}", get_job }, under /api/v1) is in the document's paths,
and every operation the document describes is in the table. A tiny line scan of the YAML (paths at
two spaces, operations at four), no packages beyond the standard library.

usage: openapi_routes_test.py <source root>"""
import re
import sys

METHODS = {"get", "put", "post", "delete", "head", "patch", "options", "trace"}


def document_routes(path):
    routes, current, in_paths = set(), None, False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.rstrip() == "paths:":
                in_paths = True
                continue
            if not in_paths or not line.strip() or line.lstrip().startswith("#"):
                continue
            if not line.startswith(" "):
                break  # the next top-level key: the paths are over
            m = re.match(r"^  (/\S*):\s*$", line)
            if m:
                current = m.group(1)
                continue
            m = re.match(r"^    ([a-z]+):", line)
            if m and m.group(1) in METHODS and current:
                routes.add((m.group(1).upper(), current))
    return routes


def handler_routes(path):
    routes = set()
    with open(path, encoding="utf-8") as f:
        for m in re.finditer(r'\{\s*"([A-Z]+)",\s*"(/[^"]*)",\s*\w+\s*\}', f.read()):
            pattern = m.group(2)
            routes.add((m.group(1), "/api/v1" + ("" if pattern == "/" else pattern)))
    return routes


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    documented = document_routes(root + "/docs/openapi.yaml")
    routed = handler_routes(root + "/gateway/src/routes.c")
    failures = 0
    for method, path in sorted(routed - documented):
        print(f"openapi_routes: {method} {path} is routed by gateway/src/routes.c but not in docs/openapi.yaml")
        failures += 1
    for method, path in sorted(documented - routed):
        print(f"openapi_routes: {method} {path} is in docs/openapi.yaml but gateway/src/routes.c does not route it")
        failures += 1
    if len(routed) < 10:
        print(f"openapi_routes: only {len(routed)} routes found in gateway/src/routes.c: the scan is broken")
        failures += 1
    print(f"openapi_routes: {len(routed)} routes, {len(documented)} documented operations, {failures} differences")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
