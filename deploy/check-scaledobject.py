"""Checks a KEDA ScaledObject's fields against KEDA's v1alpha1 API, whose CRD schema
kubernetes-validate does not ship: known keys only, a target that is the worker Deployment,
scale to zero, and a Prometheus trigger on spindle_tiles_queued.

Usage: check-scaledobject.py SCALEDOBJECT.yaml DEPLOYMENT.yaml
"""

import sys

import yaml

SPEC_KEYS = {
    "scaleTargetRef", "pollingInterval", "initialCooldownPeriod", "cooldownPeriod",
    "idleReplicaCount", "minReplicaCount", "maxReplicaCount", "fallback", "advanced", "triggers",
}
TARGET_KEYS = {"apiVersion", "kind", "name", "envSourceContainerName"}
TRIGGER_KEYS = {"type", "name", "metadata", "authenticationRef", "metricType", "useCachedMetrics"}
PROMETHEUS_KEYS = {
    "serverAddress", "query", "threshold", "activationThreshold", "namespace", "customHeaders",
    "ignoreNullValues", "unsafeSsl", "queryParameters", "timeout",
}


def check(obj, deployment):
    errors = []

    def unknown(where, value, known):
        for key in set(value) - known:
            errors.append(f"{where}.{key}: not a field of KEDA's ScaledObject")

    if obj.get("apiVersion") != "keda.sh/v1alpha1" or obj.get("kind") != "ScaledObject":
        errors.append("apiVersion/kind: expected keda.sh/v1alpha1 ScaledObject")
    unknown("", obj, {"apiVersion", "kind", "metadata", "spec"})
    spec = obj.get("spec", {})
    unknown("spec", spec, SPEC_KEYS)
    target = spec.get("scaleTargetRef", {})
    unknown("spec.scaleTargetRef", target, TARGET_KEYS)
    if target.get("name") != deployment["metadata"]["name"]:
        errors.append(f"spec.scaleTargetRef.name: {target.get('name')!r} is not the worker Deployment")
    for key in ("pollingInterval", "cooldownPeriod", "minReplicaCount", "maxReplicaCount"):
        if not isinstance(spec.get(key, 0), int):
            errors.append(f"spec.{key}: must be an integer")
    if spec.get("minReplicaCount") != 0:
        errors.append("spec.minReplicaCount: must be 0 (idle farms scale to zero)")
    if not spec.get("maxReplicaCount", 0) >= 1:
        errors.append("spec.maxReplicaCount: must be at least 1")
    triggers = spec.get("triggers") or []
    if not triggers:
        errors.append("spec.triggers: empty")
    for i, trigger in enumerate(triggers):
        where = f"spec.triggers[{i}]"
        unknown(where, trigger, TRIGGER_KEYS)
        if trigger.get("type") != "prometheus":
            errors.append(f"{where}.type: expected prometheus")
            continue
        meta = trigger.get("metadata", {})
        unknown(f"{where}.metadata", meta, PROMETHEUS_KEYS)
        for key, value in meta.items():
            if not isinstance(value, str):
                errors.append(f"{where}.metadata.{key}: trigger metadata values are strings")
        for key in ("serverAddress", "query", "threshold"):
            if key not in meta:
                errors.append(f"{where}.metadata.{key}: required")
        if "spindle_tiles_queued" not in meta.get("query", ""):
            errors.append(f"{where}.metadata.query: does not read spindle_tiles_queued")
        try:
            float(meta.get("threshold", "x"))
        except ValueError:
            errors.append(f"{where}.metadata.threshold: not a number")
    return errors


def main():
    with open(sys.argv[1]) as f:
        obj = yaml.safe_load(f)
    with open(sys.argv[2]) as f:
        deployment = yaml.safe_load(f)
    errors = check(obj, deployment)
    for e in errors:
        print(f"{sys.argv[1]}: {e}", file=sys.stderr)
    sys.exit(1 if errors else 0)


if __name__ == "__main__":
    main()
