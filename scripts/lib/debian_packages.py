#!/usr/bin/python3
"""The Debian packages package.xml needs, through scripts/lib/rosdep.yaml (rosdep key -> Debian packages).

Usage: debian_packages.py            every Debian package of every dependency (build, exec, test), one a line
       debian_packages.py --check    every key of package.xml mapped and every mapped key used; exit 1 if not
"""
import os
import sys

import yaml
from catkin_pkg.package import parse_package

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def keys_of_package():
    package = parse_package(os.path.join(ROOT, "package.xml"))
    package.evaluate_conditions(os.environ)
    lists = [package.buildtool_depends, package.build_depends, package.build_export_depends,
             package.exec_depends, package.test_depends, package.doc_depends]
    return sorted({d.name for deps in lists for d in deps if d.evaluated_condition is not False})


def mapping():
    with open(os.path.join(ROOT, "scripts", "lib", "rosdep.yaml")) as f:
        return yaml.safe_load(f)


def main():
    keys, rules = keys_of_package(), mapping()
    problems = ["package.xml's key '%s' has no Debian package in scripts/lib/rosdep.yaml" % k
                for k in keys if k not in rules or not rules[k].get("debian")]
    if "--check" in sys.argv[1:]:
        problems += ["scripts/lib/rosdep.yaml maps '%s', which package.xml does not use" % k
                     for k in sorted(rules) if k not in keys]
        for p in problems:
            print(p, file=sys.stderr)
        return 1 if problems else 0
    if problems:
        print("\n".join(problems), file=sys.stderr)
        return 1
    print("\n".join(sorted({p for k in keys for p in rules[k]["debian"]})))
    return 0


if __name__ == "__main__":
    sys.exit(main())
