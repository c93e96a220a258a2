#!/usr/bin/env python3
"""Run a `softsense batch` manifest on a Ray cluster: one Ray task per item.

    python python/examples/ray_batch.py scenarios/batch/bundled.toml --out /tmp/bundled
    python python/examples/ray_batch.py MANIFEST --out DIR --address auto     # an existing cluster

Each task writes the item's result file exactly as `softsense batch` does
(OUT/results/ID.json), so the output folder is the same whichever ran it, and either
resumes the other: items with a result are skipped (failed ones only with
--retry-failed). Without --address, Ray starts locally with --num-cpus CPUs. Every worker
needs the `softsense` package (pip install .) and the manifest's files at the same paths.
See docs/scale-out.md.
"""

import argparse
import sys
import time

import ray

import softsense.batch


@ray.remote
def run_item(manifest: str, item_id: str, out: str) -> dict:
    # One item per task, its frames one at a time: the cluster's parallelism is the items.
    return softsense.batch.run_item(manifest, item_id, out, window=1)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("manifest")
    ap.add_argument("--out", required=True, help="output folder (results/ID.json per item)")
    ap.add_argument("--address", help="Ray cluster address (default: start Ray locally)")
    ap.add_argument("--num-cpus", type=int, default=None, help="CPUs of a local Ray (default: all)")
    ap.add_argument("--retry-failed", action="store_true", help="run items that failed before again")
    args = ap.parse_args()

    plan = softsense.batch.plan(args.manifest, args.out, args.retry_failed)
    print(
        f"{len(plan.todo)} to run, {plan.done} done before, {len(plan.failed)} failed before"
        + (" (not retried: --retry-failed)" if plan.failed else ""),
        file=sys.stderr,
    )
    if args.address:
        ray.init(address=args.address)
    else:
        ray.init(num_cpus=args.num_cpus, include_dashboard=False)
    clock = time.time()
    pending = [run_item.remote(args.manifest, i, args.out) for i in plan.todo]
    failed = 0
    while pending:
        ready, pending = ray.wait(pending, num_returns=1)
        o = ray.get(ready[0])
        if o["error"] is None:
            print(f"{o['id']}: {o['sensed']}/{o['frames']} frames sensed ({o['seconds']:.1f} s)", file=sys.stderr)
        else:
            failed += 1
            print(f"{o['id']}: failed: {o['error']}", file=sys.stderr)
    print(
        f"{len(plan.todo) - failed} of {len(plan.todo)} items done, {failed} failed, "
        f"{time.time() - clock:.1f} s; results in {args.out}/results",
        file=sys.stderr,
    )
    return 1 if failed or plan.failed else 0


if __name__ == "__main__":
    sys.exit(main())
