#!/usr/bin/python3
"""Offline checks of Strata's deployment files (run by CTest, see CMakeLists.txt beside).

  k8s        renders deploy/k8s with `kubectl kustomize` and checks every object against the
             hand-written schema (k8s_schema.yaml) and the cross-object rules below; then each
             file of deploy/k8s/optional/ the same way, with the rendered objects it would join
  broken     applies each deliberate breakage of broken_cases.yaml to the good files and
             requires the matching check to reject it with the expected message; also requires
             `kubectl kustomize` to fail on a broken kustomization
  compose    checks deploy/compose.yaml and the Prometheus configs (structure and references;
             `docker-compose config` and `promtool check config` too when installed)
  probe      strata-health-probe against a real strata-server: SERVING, unknown service,
             unreachable server, bad arguments

Uses only Debian's /usr/bin/python3 with python3-yaml (no pip, no network).
"""
import argparse
import copy
import os
import re
import shutil
import subprocess
import sys

import yaml


class Problems:
    """Collects error messages; a check passes when there are none."""

    def __init__(self):
        self.errors = []

    def add(self, where, message):
        self.errors.append(f"{where}: {message}")


# ---------------------------------------------------------------------------------------------
# Schema validation

DNS_LABEL = re.compile(r"^[a-z0-9]([-a-z0-9]*[a-z0-9])?$")
DNS_SUBDOMAIN = re.compile(r"^[a-z0-9]([-a-z0-9]*[a-z0-9])?(\.[a-z0-9]([-a-z0-9]*[a-z0-9])?)*$")
IANA_SVC_NAME = re.compile(r"^(?=.*[a-z])[a-z0-9]([a-z0-9-]*[a-z0-9])?$")
LABEL_NAME = re.compile(r"^([A-Za-z0-9]([-A-Za-z0-9_.]*[A-Za-z0-9])?)?$")
QUANTITY = re.compile(r"^[+-]?([0-9]+(\.[0-9]*)?|\.[0-9]+)([eE][+-]?[0-9]+|Ki|Mi|Gi|Ti|Pi|Ei|n|u|m|k|M|G|T|P|E)?$")
PERCENT = re.compile(r"^[0-9]+%$")


def is_int(value):
    return isinstance(value, int) and not isinstance(value, bool)


def check_label_key(key):
    prefix, _, name = key.rpartition("/")
    if prefix and (len(prefix) > 253 or not DNS_SUBDOMAIN.match(prefix)):
        return False
    return 0 < len(name) <= 63 and LABEL_NAME.match(name) is not None


def check_scalar(kind, value, where, problems):
    """Checks a scalar type; returns True when `kind` is a scalar type name."""
    if kind == "string":
        if not isinstance(value, str):
            problems.add(where, f"want a string, got {value!r}")
    elif kind == "boolean":
        if not isinstance(value, bool):
            problems.add(where, f"want true or false, got {value!r}")
    elif kind in ("integer", "int32"):
        if not is_int(value) or (kind == "int32" and not -2**31 <= value < 2**31):
            problems.add(where, f"want an integer, got {value!r}")
    elif kind == "port":
        if not is_int(value) or not 1 <= value <= 65535:
            problems.add(where, f"want a port number 1-65535, got {value!r}")
    elif kind == "quantity":
        if not (is_int(value) or isinstance(value, float)
                or (isinstance(value, str) and QUANTITY.match(value))):
            problems.add(where, f"want a quantity such as 500m, 2 or 1Gi, got {value!r}")
    elif kind == "int-or-string":
        if is_int(value):
            if not 1 <= value <= 65535:
                problems.add(where, f"want a port number 1-65535 or a port name, got {value!r}")
        elif not (isinstance(value, str) and len(value) <= 15 and IANA_SVC_NAME.match(value)):
            problems.add(where, f"want a port number or a port name, got {value!r}")
    elif kind == "int-or-percent":
        if not (is_int(value) and value >= 0) and not (isinstance(value, str) and PERCENT.match(value)):
            problems.add(where, f"want a count or a percentage such as 25%, got {value!r}")
    elif kind == "dns-label":
        if not (isinstance(value, str) and len(value) <= 63 and DNS_LABEL.match(value)):
            problems.add(where, f"want a DNS label (lower case, digits, '-', <= 63), got {value!r}")
    elif kind == "dns-subdomain":
        if not (isinstance(value, str) and len(value) <= 253 and DNS_SUBDOMAIN.match(value)):
            problems.add(where, f"want a DNS subdomain name, got {value!r}")
    elif kind == "iana-svc-name":
        if not (isinstance(value, str) and len(value) <= 15 and IANA_SVC_NAME.match(value)):
            problems.add(where, f"want a port name (<= 15 lower-case letters, digits, '-'), got {value!r}")
    elif kind == "labels":
        if not isinstance(value, dict):
            problems.add(where, f"want a map of labels, got {value!r}")
            return True
        for key, label in value.items():
            if not isinstance(key, str) or not check_label_key(key):
                problems.add(where, f"invalid label key {key!r}")
            if not isinstance(label, str) or len(label) > 63 or not LABEL_NAME.match(label):
                problems.add(f"{where}.{key}", f"invalid label value {label!r} (a string, <= 63 characters)")
    else:
        return False
    return True


def validate(value, type_expr, schema, where, problems):
    """Validates `value` against a type expression of the schema."""
    if type_expr.startswith("[") and type_expr.endswith("]"):
        if not isinstance(value, list):
            problems.add(where, f"want a list, got {value!r}")
            return
        for i, item in enumerate(value):
            validate(item, type_expr[1:-1], schema, f"{where}[{i}]", problems)
        return
    if type_expr.startswith("{") and type_expr.endswith("}"):
        if not isinstance(value, dict):
            problems.add(where, f"want a map, got {value!r}")
            return
        for key, item in value.items():
            if not isinstance(key, str):
                problems.add(where, f"map key {key!r} is not a string")
            validate(item, type_expr[1:-1], schema, f"{where}.{key}", problems)
        return
    if type_expr.startswith("enum:"):
        allowed = type_expr[len("enum:"):].split("|")
        if value not in allowed:
            problems.add(where, f"want one of {allowed}, got {value!r}")
        return
    if check_scalar(type_expr, value, where, problems):
        return
    definition = schema["types"].get(type_expr)
    if definition is None:
        raise KeyError(f"schema: unknown type {type_expr!r} (at {where})")
    if not isinstance(value, dict):
        problems.add(where, f"want an object ({type_expr}), got {value!r}")
        return
    fields = definition.get("fields", {})
    for key, item in value.items():
        if key not in fields:
            problems.add(where, f"unknown field '{key}' in {type_expr}")
            continue
        validate(item, fields[key], schema, f"{where}.{key}", problems)
    for key in definition.get("required", []):
        if key not in value:
            problems.add(where, f"missing required field '{key}' of {type_expr}")
    present = [key for key in definition.get("exactly_one", []) if key in value]
    if definition.get("exactly_one") and len(present) != 1:
        problems.add(where, f"want exactly one of {definition['exactly_one']}, got {present}")
    present = [key for key in definition.get("at_most_one", []) if key in value]
    if len(present) > 1:
        problems.add(where, f"want at most one of {definition['at_most_one']}, got {present}")


def object_name(obj):
    meta = obj.get("metadata") if isinstance(obj, dict) else None
    name = meta.get("name") if isinstance(meta, dict) else None
    return f"{obj.get('kind', '?')}/{name}" if isinstance(obj, dict) else repr(obj)


def validate_objects(objects, schema, problems):
    for obj in objects:
        where = object_name(obj)
        if not isinstance(obj, dict):
            problems.add(where, "not a mapping")
            continue
        key = f"{obj.get('apiVersion')} {obj.get('kind')}"
        root = schema["kinds"].get(key)
        if root is None:
            problems.add(where, f"kind '{key}' is not in the schema (known: {sorted(schema['kinds'])})")
            continue
        validate(obj, root, schema, where, problems)


# ---------------------------------------------------------------------------------------------
# Cross-object rules for deploy/k8s


def labels_match(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def get(obj, *path, default=None):
    for key in path:
        if isinstance(obj, dict) and key in obj:
            obj = obj[key]
        elif isinstance(obj, list) and isinstance(key, int) and 0 <= key < len(obj):
            obj = obj[key]
        else:
            return default
    return obj


def check_rules(objects, problems, required_kinds):
    """Rules the schema cannot express. Assumes the schema check ran (tolerates bad shapes)."""
    by_kind = {}
    for obj in objects:
        if isinstance(obj, dict):
            by_kind.setdefault(obj.get("kind"), []).append(obj)
            names = [object_name(o) for o in by_kind[obj.get("kind")]]
            if names.count(object_name(obj)) > 1:
                problems.add(object_name(obj), "defined twice")
    for kind in required_kinds:
        if kind not in by_kind:
            problems.add("render", f"no {kind} rendered")
    deployments = by_kind.get("Deployment", [])
    statefulsets = by_kind.get("StatefulSet", [])
    workloads = deployments + statefulsets
    services = {get(o, "metadata", "name"): o for o in by_kind.get("Service", [])}
    pvcs = {get(o, "metadata", "name") for o in by_kind.get("PersistentVolumeClaim", [])}
    hpas = {(get(h, "spec", "scaleTargetRef", "kind"), get(h, "spec", "scaleTargetRef", "name")): h
            for h in by_kind.get("HorizontalPodAutoscaler", [])}

    def pod_labels(workload):
        return get(workload, "spec", "template", "metadata", "labels", default={}) or {}

    def ports_of(workload):
        ports = {}
        for container in get(workload, "spec", "template", "spec", "containers", default=[]) or []:
            for port in container.get("ports", []) or []:
                ports[port.get("name")] = port.get("containerPort")
        return ports

    def workloads_selected(selector):
        return [w for w in workloads if labels_match(selector, pod_labels(w))]

    def least_replicas(workload):
        """The fewest pods the workload runs: its HPA's floor, else spec.replicas (default 1)."""
        hpa = hpas.get((workload.get("kind"), get(workload, "metadata", "name")))
        if hpa is not None:
            return get(hpa, "spec", "minReplicas", default=1)
        return get(workload, "spec", "replicas", default=1)

    for d in workloads:
        where = object_name(d)
        kind = d.get("kind")
        if not labels_match(get(d, "spec", "selector", "matchLabels", default={}), pod_labels(d)):
            problems.add(where, "spec.selector.matchLabels does not match the pod template's labels")
        if (kind, get(d, "metadata", "name")) in hpas and "replicas" in d.get("spec", {}):
            problems.add(where, f"spec.replicas is set but an HPA scales this {kind} "
                                "(every apply would reset the HPA's count)")
        pod = get(d, "spec", "template", "spec", default={}) or {}
        pod_security = pod.get("securityContext", {}) or {}
        volumes = {v.get("name"): v for v in pod.get("volumes", []) or []}
        claim_templates = {get(t, "metadata", "name") for t in get(d, "spec", "volumeClaimTemplates", default=[]) or []}
        mounted = set()
        for i, c in enumerate(pod.get("containers", []) or []):
            cw = f"{where} container {c.get('name', i)}"
            declared = {p.get("containerPort") for p in c.get("ports", []) or []}
            names = {p.get("name") for p in c.get("ports", []) or []} - {None}
            # strata-server: readiness is its health service (preloads ACTIVE, SIGTERM drains).
            if kind == "Deployment":
                for probe in ("readinessProbe", "livenessProbe"):
                    if "grpc" not in (c.get(probe) or {}):
                        problems.add(cw, f"{probe} must be a native gRPC probe (grpc:)")
            for probe in ("startupProbe", "readinessProbe", "livenessProbe"):
                port = get(c, probe, "grpc", "port")
                if port is not None and port not in declared:
                    problems.add(cw, f"{probe}.grpc.port {port!r} is not one of the container's ports {sorted(declared)}")
                for handler in ("httpGet", "tcpSocket"):
                    port = get(c, probe, handler, "port")
                    if port is not None and port not in (names if isinstance(port, str) else declared):
                        problems.add(cw, f"{probe}.{handler}.port {port!r} is not one of the container's "
                                         f"ports {sorted(names)} {sorted(declared)}")
            env = {e.get("name"): e.get("value") for e in c.get("env", []) or []}
            http = env.get("STRATA_HTTP_PORT")
            if http is not None and int(http) >= 0 and int(http) not in declared:
                problems.add(cw, f"STRATA_HTTP_PORT {http} (the web viewer) is not one of the "
                                 f"container's ports {sorted(declared)}")
            if env.get("STRATA_ETCD") is not None:
                check_etcd_endpoints(cw, env["STRATA_ETCD"], services, statefulsets, ports_of, problems)
            tokens = env.get("STRATA_AUTH_TOKENS")
            if tokens and not any(tokens.startswith(str(m.get("mountPath", "")).rstrip("/") + "/")
                                  for m in c.get("volumeMounts", []) or []):
                problems.add(cw, f"STRATA_AUTH_TOKENS {tokens} is under no volumeMount (the server "
                                 "refuses to start without the file)")
            resources = c.get("resources", {}) or {}
            for section, key in (("requests", "cpu"), ("requests", "memory"), ("limits", "memory")):
                if key not in (resources.get(section) or {}):
                    problems.add(cw, f"resources.{section}.{key} is missing (the HPA scales on CPU "
                                     "requests; memory bounds keep maps from starving the node)")
            security = c.get("securityContext", {}) or {}
            if not security.get("runAsNonRoot", pod_security.get("runAsNonRoot", False)):
                problems.add(cw, "runAsNonRoot is not true (container or pod securityContext)")
            if security.get("runAsUser", pod_security.get("runAsUser")) == 0:
                problems.add(cw, "runAsUser is 0 (root)")
            if security.get("readOnlyRootFilesystem") is not True:
                problems.add(cw, "securityContext.readOnlyRootFilesystem is not true")
            if security.get("allowPrivilegeEscalation") is not False:
                problems.add(cw, "securityContext.allowPrivilegeEscalation is not false")
            for mount in c.get("volumeMounts", []) or []:
                mounted.add(mount.get("name"))
                if mount.get("name") not in volumes and mount.get("name") not in claim_templates:
                    problems.add(cw, f"volumeMount {mount.get('name')!r} names no pod volume"
                                     + (" or volumeClaimTemplate" if kind == "StatefulSet" else ""))
        for name, volume in volumes.items():
            if name not in mounted:
                problems.add(where, f"volume {name!r} is mounted by no container")
            claim = get(volume, "persistentVolumeClaim", "claimName")
            if claim is not None and claim not in pvcs:
                problems.add(where, f"volume {name!r} claims PersistentVolumeClaim {claim!r}, which is not rendered")
        for name in claim_templates - mounted:
            problems.add(where, f"volumeClaimTemplate {name!r} is mounted by no container")
        for i, spread in enumerate(pod.get("topologySpreadConstraints", []) or []):
            if not labels_match(get(spread, "labelSelector", "matchLabels", default={}) or {}, pod_labels(d)):
                problems.add(where, f"topologySpreadConstraints[{i}].labelSelector does not select "
                                    "this workload's own pods (it would spread nothing)")

    # A StatefulSet's pods are named through its governing Service: headless, selecting them.
    for st in statefulsets:
        where = object_name(st)
        governing = services.get(get(st, "spec", "serviceName"))
        if governing is None or get(governing, "spec", "clusterIP") != "None":
            problems.add(where, f"spec.serviceName {get(st, 'spec', 'serviceName')!r} names no rendered "
                                "headless Service (its pods' DNS names come from it)")
        elif st not in workloads_selected(get(governing, "spec", "selector", default={}) or {}):
            problems.add(where, f"its Service {get(st, 'spec', 'serviceName')!r} does not select its pods")

    for s in by_kind.get("Service", []):
        where = object_name(s)
        spec = s.get("spec", {}) or {}
        selected = workloads_selected(spec.get("selector") or {})
        if not selected:
            problems.add(where, "spec.selector matches no workload's pods (Deployment, StatefulSet)")
        headless = spec.get("clusterIP") == "None"
        for port in spec.get("ports", []) or []:
            pw = f"{where} port {port.get('name', port.get('port'))}"
            target = port.get("targetPort", port.get("port"))
            for d in selected:
                ports = ports_of(d)
                number = ports.get(target) if isinstance(target, str) else target
                if number not in ports.values():
                    problems.add(pw, f"targetPort {target!r} is not a container port of {object_name(d)}")
                elif headless and number != port.get("port"):
                    problems.add(pw, f"headless Service: port {port.get('port')} must equal the container "
                                     f"port {number} (clients connect to the pods directly)")
            if port.get("name") == "grpc" and not port.get("appProtocol"):
                problems.add(pw, "the grpc port has no appProtocol")

    for h in by_kind.get("HorizontalPodAutoscaler", []):
        where = object_name(h)
        ref = get(h, "spec", "scaleTargetRef", default={}) or {}
        if not any(ref.get("kind") == "Deployment" and ref.get("apiVersion") == d.get("apiVersion")
                   and ref.get("name") == get(d, "metadata", "name") for d in deployments):
            problems.add(where, f"scaleTargetRef {ref} names no rendered Deployment")
        low, high = get(h, "spec", "minReplicas", default=1), get(h, "spec", "maxReplicas")
        if is_int(low) and is_int(high) and not 1 <= low <= high:
            problems.add(where, f"want 1 <= minReplicas ({low}) <= maxReplicas ({high})")
        metrics = get(h, "spec", "metrics", default=[]) or []
        for i, metric in enumerate(metrics):
            wanted = {"Resource": "resource", "ContainerResource": "containerResource", "Pods": "pods",
                      "Object": "object", "External": "external"}.get(metric.get("type"))
            if wanted and wanted not in metric:
                problems.add(where, f"metrics[{i}]: type {metric.get('type')} wants the field '{wanted}'")
        # CPU stays as the fallback beside any custom metric: the HPA still scales up on it
        # when the metrics adapter is down.
        if not any(get(m, "resource", "name") == "cpu" for m in metrics):
            problems.add(where, "no CPU resource metric")

    for p in by_kind.get("PodDisruptionBudget", []):
        where = object_name(p)
        selected = workloads_selected(get(p, "spec", "selector", "matchLabels", default={}) or {})
        if not selected:
            problems.add(where, "spec.selector matches no workload's pods (Deployment, StatefulSet)")
        least = get(p, "spec", "minAvailable")
        for w in selected:
            replicas = least_replicas(w)
            if is_int(least) and is_int(replicas) and least >= replicas:
                problems.add(where, f"minAvailable {least} >= the {replicas} pods {object_name(w)} runs at "
                                    "least: no node could ever be drained")

    for n in by_kind.get("NetworkPolicy", []):
        where = object_name(n)
        selected = workloads_selected(get(n, "spec", "podSelector", "matchLabels", default={}) or {})
        if not selected:
            problems.add(where, "spec.podSelector matches no workload's pods (Deployment, StatefulSet)")
        for direction, peers_key in (("ingress", "from"), ("egress", "to")):
            for i, rule in enumerate(get(n, "spec", direction, default=[]) or []):
                rw = f"{where} {direction}[{i}]"
                if direction == "ingress":
                    for port in rule.get("ports", []) or []:
                        number = port.get("port")
                        for w in selected:
                            ports = ports_of(w)
                            if number is not None and number not in (ports if isinstance(number, str) else ports.values()):
                                problems.add(rw, f"port {number!r} is not a container port of {object_name(w)} "
                                                 f"({sorted(k for k in ports if k)})")
                for peer in rule.get(peers_key, []) or []:
                    # A podSelector alone means pods of this namespace: they should exist here.
                    if "podSelector" in peer and "namespaceSelector" not in peer:
                        if not workloads_selected(get(peer, "podSelector", "matchLabels", default={}) or {}):
                            problems.add(rw, f"peer podSelector {get(peer, 'podSelector', 'matchLabels')} "
                                             "matches no workload's pods")


def check_etcd_endpoints(where, value, services, statefulsets, ports_of, problems):
    """STRATA_ETCD: HOST:PORT,... (an http:// or https:// prefix allowed, as the server does).
    Endpoints named POD.SERVICE after a rendered Service must be pods of the StatefulSet it
    governs, on one of its ports; other hosts are an etcd outside."""
    for endpoint in value.split(","):
        endpoint = re.sub(r"^https?://", "", endpoint.strip())
        if not endpoint:
            continue
        host, _, port = endpoint.rpartition(":")
        if not host or not port.isdigit():
            problems.add(where, f"STRATA_ETCD endpoint {endpoint!r}: want HOST:PORT")
            continue
        labels = host.split(".")
        if len(labels) < 2 or labels[1] not in services:
            continue
        owners = [st for st in statefulsets if get(st, "spec", "serviceName") == labels[1]]
        pod = re.match(r"^(.+)-([0-9]+)$", labels[0])
        owner = next((st for st in owners if pod and get(st, "metadata", "name") == pod.group(1)), None)
        if owner is None or int(pod.group(2)) >= get(owner, "spec", "replicas", default=1):
            known = [f"{object_name(st)} with {get(st, 'spec', 'replicas', default=1)} replicas" for st in owners]
            problems.add(where, f"STRATA_ETCD endpoint {endpoint!r} names no pod of a StatefulSet "
                                f"governed by Service {labels[1]!r} ({', '.join(known) or 'none'})")
        else:
            ports = ports_of(owner)
            # etcd's port named client when it names one (not peer 2380 or metrics).
            wanted = {ports["client"]} if "client" in ports else set(ports.values())
            if int(port) not in wanted:
                problems.add(where, f"STRATA_ETCD endpoint {endpoint!r}: port {port} is not the client port "
                                    f"of {object_name(owner)} {sorted(wanted)}")


def render_kustomization(kubectl, directory):
    """Returns (objects, error)."""
    result = subprocess.run([kubectl, "kustomize", directory], capture_output=True, text=True)
    if result.returncode != 0:
        return None, f"kubectl kustomize {directory} failed ({result.returncode}): {result.stderr.strip()}"
    try:
        return [o for o in yaml.safe_load_all(result.stdout) if o is not None], None
    except yaml.YAMLError as e:
        return None, f"kubectl kustomize {directory}: output is not YAML: {e}"


def check_k8s_objects(objects, schema):
    problems = Problems()
    validate_objects(objects, schema, problems)
    check_rules(objects, problems, ["Deployment", "Service", "HorizontalPodAutoscaler",
                                    "PodDisruptionBudget", "NetworkPolicy"])
    return problems.errors


# ---------------------------------------------------------------------------------------------
# Compose and Prometheus

COMPOSE_TOP = {"name", "services", "volumes", "networks", "configs", "secrets"}
# The Compose Specification's service keys this project may use (a subset: a typo fails).
COMPOSE_SERVICE = {
    "build", "image", "command", "entrypoint", "environment", "env_file", "ports", "expose",
    "volumes", "tmpfs", "read_only", "user", "cap_drop", "cap_add", "security_opt",
    "healthcheck", "depends_on", "restart", "stop_grace_period", "stop_signal", "networks",
    "deploy", "labels", "init", "ulimits", "mem_limit", "cpus", "container_name", "working_dir",
}
DURATION = re.compile(r"^([0-9]+(\.[0-9]+)?(us|ms|s|m|h))+$")
PROM_DURATION = re.compile(r"^([0-9]+(ms|s|m|h|d|w|y))+$")


def interpolate(value, environ=None):
    """Compose's variable substitution (${VAR}, ${VAR:-default}, ${VAR-default}, $$)."""
    environ = os.environ if environ is None else environ
    if isinstance(value, dict):
        return {k: interpolate(v, environ) for k, v in value.items()}
    if isinstance(value, list):
        return [interpolate(v, environ) for v in value]
    if not isinstance(value, str):
        return value

    def substitute(match):
        if match.group(0) == "$$":
            return "$"
        name, op, default = match.group(1), match.group(2), match.group(3) or ""
        if op == ":-":
            return environ.get(name) or default
        if op == "-":
            return environ.get(name, default)
        return environ.get(name, "")

    return re.sub(r"\$\$|\$\{([A-Za-z_][A-Za-z0-9_]*)(?:(:?-)([^}]*))?\}", substitute, value)


def env_of(service):
    env = service.get("environment") or {}
    if isinstance(env, list):
        env = dict(item.split("=", 1) if "=" in item else (item, "") for item in env)
    return {k: str(v) for k, v in env.items()}


def published(service):
    """Container port -> host port, from short-syntax "HOST:CONTAINER" strings."""
    ports = {}
    for entry in service.get("ports") or []:
        text = str(entry)
        match = re.match(r"^(?:[0-9.]+:)?([0-9]+):([0-9]+)(/tcp|/udp)?$", text)
        if not match:
            raise ValueError(f"port {entry!r}: want \"HOST:CONTAINER\"")
        ports[int(match.group(2))] = int(match.group(1))
    return ports


def check_compose(compose_path, compose):
    problems = Problems()
    compose = interpolate(compose, {})  # the defaults, as with an empty environment
    base = os.path.dirname(os.path.abspath(compose_path))
    where = os.path.basename(compose_path)
    if not isinstance(compose, dict):
        return [f"{where}: not a mapping"]
    for key in compose:
        if key not in COMPOSE_TOP:
            problems.add(where, f"unknown top-level key '{key}'")
    services = compose.get("services")
    if not isinstance(services, dict) or not services:
        problems.add(where, "no services")
        return problems.errors
    for name, service in services.items():
        sw = f"{where} service {name}"
        if not isinstance(service, dict):
            problems.add(sw, "not a mapping")
            continue
        for key in service:
            if key not in COMPOSE_SERVICE:
                problems.add(sw, f"unknown key '{key}'")
        if "image" not in service and "build" not in service:
            problems.add(sw, "neither image nor build")
        build = service.get("build")
        if isinstance(build, dict):
            context = os.path.normpath(os.path.join(base, build.get("context", ".")))
            dockerfile = os.path.join(context, build.get("dockerfile", "Dockerfile"))
            if not os.path.isfile(dockerfile):
                problems.add(sw, f"build: no Dockerfile at {os.path.relpath(dockerfile, base)}")
        try:
            ports = published(service)
        except ValueError as e:
            problems.add(sw, str(e))
            ports = {}
        for volume in service.get("volumes") or []:
            parts = str(volume).split(":")
            if len(parts) < 2 or not parts[1].startswith("/"):
                problems.add(sw, f"volume {volume!r}: want SOURCE:/TARGET[:ro]")
            elif parts[0].startswith(".") and "." in os.path.basename(parts[0]):
                if not os.path.exists(os.path.join(base, parts[0])):
                    problems.add(sw, f"volume {volume!r}: {parts[0]} does not exist")
        health = service.get("healthcheck")
        if health is not None:
            test = health.get("test") if isinstance(health, dict) else None
            if not (isinstance(test, list) and test and test[0] in ("CMD", "CMD-SHELL", "NONE")):
                problems.add(sw, "healthcheck.test: want a list starting with CMD or CMD-SHELL")
            for key in ("interval", "timeout", "start_period"):
                if key in health and not DURATION.match(str(health[key])):
                    problems.add(sw, f"healthcheck.{key}: want a duration such as 15s, got {health[key]!r}")
        for key in ("stop_grace_period",):
            if key in service and not DURATION.match(str(service[key])):
                problems.add(sw, f"{key}: want a duration such as 30s")
        depends = service.get("depends_on") or {}
        for other, condition in (depends.items() if isinstance(depends, dict) else ((d, {}) for d in depends)):
            if other not in services:
                problems.add(sw, f"depends_on names no service {other!r}")
            elif (condition or {}).get("condition") == "service_healthy" and "healthcheck" not in services[other]:
                problems.add(sw, f"depends_on {other} service_healthy, but {other} has no healthcheck")
        env = env_of(service)
        if "STRATA_LISTEN" in env or name == "server":
            listen = env.get("STRATA_LISTEN", "0.0.0.0:50051")
            port = int(listen.rsplit(":", 1)[1])
            if port not in ports:
                problems.add(sw, f"STRATA_LISTEN port {port} is not published ({sorted(ports)})")
            metrics = int(env.get("STRATA_METRICS_PORT", "9090"))
            if metrics >= 0 and metrics not in ports:
                problems.add(sw, f"STRATA_METRICS_PORT {metrics} is not published ({sorted(ports)})")
            http = int(env.get("STRATA_HTTP_PORT", "-1"))
            if http >= 0 and http not in ports:
                problems.add(sw, f"STRATA_HTTP_PORT {http} is not published ({sorted(ports)})")
            root = env.get("STRATA_MAP_ROOT")
            targets = [str(v).split(":")[1] for v in service.get("volumes") or [] if ":" in str(v)]
            if root and root not in targets:
                problems.add(sw, f"STRATA_MAP_ROOT {root} is not a mounted volume")
            if not health:
                problems.add(sw, "strata-server without a healthcheck")
    return problems.errors


def check_prometheus(path, config, compose=None, promtool=None):
    problems = Problems()
    where = os.path.basename(path)
    if not isinstance(config, dict):
        return [f"{where}: not a mapping"]
    for key in config:
        if key not in {"global", "scrape_configs", "rule_files", "alerting", "remote_write", "remote_read", "storage"}:
            problems.add(where, f"unknown top-level key '{key}'")
    for key, value in (config.get("global") or {}).items():
        if key in ("scrape_interval", "scrape_timeout", "evaluation_interval") and not PROM_DURATION.match(str(value)):
            problems.add(where, f"global.{key}: want a duration, got {value!r}")
    jobs = config.get("scrape_configs")
    if not isinstance(jobs, list) or not jobs:
        problems.add(where, "no scrape_configs")
        jobs = []
    names = [j.get("job_name") for j in jobs if isinstance(j, dict)]
    for job in jobs:
        jw = f"{where} job {job.get('job_name')}"
        if not job.get("job_name"):
            problems.add(where, "a scrape config without job_name")
        if names.count(job.get("job_name")) > 1:
            problems.add(jw, "job_name used twice")
        if not (job.get("static_configs") or job.get("kubernetes_sd_configs")):
            problems.add(jw, "no static_configs or kubernetes_sd_configs")
        for static in job.get("static_configs") or []:
            for target in static.get("targets") or []:
                match = re.match(r"^([A-Za-z0-9.-]+):([0-9]+)$", str(target))
                if not match:
                    problems.add(jw, f"target {target!r}: want host:port")
                    continue
                if compose is not None:
                    compose = interpolate(compose, {})
                    service = (compose.get("services") or {}).get(match.group(1))
                    if service is None:
                        problems.add(jw, f"target {target}: no compose service {match.group(1)!r}")
                    elif match.group(1) == "server":
                        metrics = int(env_of(service).get("STRATA_METRICS_PORT", "9090"))
                        if int(match.group(2)) != metrics:
                            problems.add(jw, f"target {target}: the server's metrics port is {metrics}")
        for relabel in job.get("relabel_configs") or []:
            if relabel.get("action", "replace") not in ("replace", "keep", "drop", "labelmap", "labeldrop", "labelkeep", "hashmod"):
                problems.add(jw, f"relabel action {relabel.get('action')!r}")
            if relabel.get("regex") is not None:
                try:
                    re.compile(str(relabel["regex"]))
                except re.error as e:
                    problems.add(jw, f"relabel regex {relabel['regex']!r}: {e}")
    # Debian's promtool is built without Kubernetes service discovery: use it for the rest.
    if promtool and not any("kubernetes_sd_configs" in j for j in jobs):
        result = subprocess.run([promtool, "check", "config", path], capture_output=True, text=True)
        if result.returncode != 0:
            problems.add(where, f"promtool check config failed: {(result.stdout + result.stderr).strip()}")
        else:
            print(f"  promtool check config {where}: SUCCESS")
    return problems.errors


# ---------------------------------------------------------------------------------------------
# Breakage cases


def parse_path(path):
    """'a.b\\.c[2].d' -> ['a', 'b.c', 2, 'd'] (a backslash keeps a dot inside a key)."""
    parts = []
    for token in re.findall(r"(?:\\.|[^.\[\]\\])+|\[\d+\]", path):
        parts.append(int(token[1:-1]) if token.startswith("[") else re.sub(r"\\(.)", r"\1", token))
    return parts


def apply_change(doc, change):
    """Applies one {set|delete|rename} change to a document (in place)."""
    op = next(k for k in ("set", "delete", "rename") if k in change)
    parts = parse_path(change["path"])
    parent = doc
    for key in parts[:-1]:
        parent = parent[key]
    last = parts[-1]
    if op == "set":
        parent[last] = change["set"]
    elif op == "delete":
        del parent[last]
    else:
        parent[change["rename"]] = parent.pop(last)


def select_object(objects, select):
    for obj in objects:
        if obj.get("kind") == select["kind"] and get(obj, "metadata", "name") == select["name"]:
            return obj
    raise KeyError(f"case selects {select}, which is not rendered")


# ---------------------------------------------------------------------------------------------
# Commands


def find_kubectl(given):
    kubectl = given or shutil.which("kubectl")
    if not kubectl:
        sys.exit("kubectl not found: scripts/install-deps.sh installs Debian's kubernetes-client")
    return kubectl


def report(errors, label):
    if errors:
        print(f"FAIL {label}:")
        for error in errors:
            print(f"  {error}")
        return 1
    print(f"ok   {label}")
    return 0


def cmd_k8s(args):
    kubectl = find_kubectl(args.kubectl)
    version = subprocess.run([kubectl, "version", "--client"], capture_output=True, text=True).stdout
    print(f"kubectl: {version.strip().splitlines()[0] if version.strip() else '?'}")
    schema = yaml.safe_load(open(args.schema))
    objects, error = render_kustomization(kubectl, args.dir)
    if error:
        return report([error], "kubectl kustomize")
    print(f"rendered {len(objects)} objects: {', '.join(object_name(o) for o in objects)}")
    status = report(check_k8s_objects(objects, schema), f"{len(objects)} objects against the schema and rules")
    # deploy/k8s/optional/: files an operator adds to (or swaps into) kustomization.yaml. Each is
    # checked with the rendered objects it would join: an object of the same kind and name is
    # replaced (optional/hpa-queue.yaml for hpa.yaml), any other added.
    optional = os.path.join(args.dir, "optional")
    for name in sorted(os.listdir(optional)) if os.path.isdir(optional) else []:
        if not name.endswith((".yaml", ".yml")):
            continue
        try:
            extra = [o for o in yaml.safe_load_all(open(os.path.join(optional, name))) if o is not None]
        except yaml.YAMLError as e:
            status |= report([f"optional/{name}: not YAML: {e}"], f"optional/{name}")
            continue
        status |= report(check_k8s_objects(with_variant(objects, extra), schema),
                         f"optional/{name} ({', '.join(object_name(o) for o in extra)}) with the others")
    return status


def with_variant(objects, extra):
    """The objects with each of `extra` in place of the one of the same kind and name, or added."""
    def key(obj):
        return (obj.get("kind"), get(obj, "metadata", "name")) if isinstance(obj, dict) else None
    replaced = {key(o): o for o in extra}
    result = [replaced.pop(key(o), o) for o in objects]
    return result + [o for o in extra if key(o) in replaced]


def cmd_broken(args):
    kubectl = find_kubectl(args.kubectl)
    schema = yaml.safe_load(open(args.schema))
    cases = yaml.safe_load(open(args.cases))
    failures = 0
    objects, error = render_kustomization(kubectl, args.dir)
    if error:
        return report([error], "kubectl kustomize (good manifests)")
    compose = yaml.safe_load(open(args.compose))
    prometheus = yaml.safe_load(open(args.prometheus))
    if check_k8s_objects(objects, schema) or check_compose(args.compose, compose) \
            or check_prometheus(args.prometheus, prometheus, compose):
        print("FAIL the good files do not pass; run the other deploy tests first")
        return 1

    for case in cases.get("kustomize", []):
        _, error = render_kustomization(kubectl, os.path.join(os.path.dirname(args.cases), case["dir"]))
        failures += expect_rejected(case, [error] if error else [])
    for case in cases.get("k8s", []):
        broken = copy.deepcopy(objects)
        if "add" in case:
            broken.append(case["add"])
        for change in case.get("changes", []):
            apply_change(select_object(broken, case["select"]), change)
        failures += expect_rejected(case, check_k8s_objects(broken, schema))
    for case in cases.get("compose", []):
        broken = copy.deepcopy(compose)
        for change in case["changes"]:
            apply_change(broken, change)
        errors = check_compose(args.compose, broken) + check_prometheus(args.prometheus, prometheus, broken)
        failures += expect_rejected(case, errors)
    for case in cases.get("prometheus", []):
        broken = copy.deepcopy(prometheus)
        for change in case["changes"]:
            apply_change(broken, change)
        failures += expect_rejected(case, check_prometheus(args.prometheus, broken, compose))
    total = sum(len(cases.get(k, [])) for k in ("kustomize", "k8s", "compose", "prometheus"))
    print(f"{total - failures} of {total} broken cases rejected as expected")
    return 1 if failures else 0


def expect_rejected(case, errors):
    wanted = re.compile(case["expect"])
    if any(wanted.search(e) for e in errors):
        print(f"ok   rejected: {case['name']}")
        return 0
    print(f"FAIL not rejected as expected: {case['name']}\n  want an error matching {case['expect']!r}, got:")
    for error in errors or ["(no error)"]:
        print(f"    {error}")
    return 1


def cmd_compose(args):
    compose = yaml.safe_load(open(args.compose))
    errors = check_compose(args.compose, compose)
    # Compose v1 (Debian's docker-compose) validates against its copy of the Compose schema.
    docker_compose = shutil.which("docker-compose")
    if docker_compose:
        result = subprocess.run([docker_compose, "-f", args.compose, "config", "-q"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            errors.append(f"docker-compose config failed: {(result.stdout + result.stderr).strip()}")
        else:
            print(f"  docker-compose config -q {os.path.basename(args.compose)}: valid")
    status = report(errors, os.path.relpath(args.compose))
    promtool = shutil.which("promtool")
    if not promtool:
        print("  (promtool not installed: Prometheus configs get the structural checks only)")
    for path in args.prometheus:
        status |= report(check_prometheus(path, yaml.safe_load(open(path)),
                                          compose if path == args.prometheus[0] else None, promtool),
                         os.path.relpath(path))
    return status


def cmd_probe(args):
    """The probe against a real server on an ephemeral loopback port."""
    errors = []

    def probe(*probe_args, env=None):
        result = subprocess.run([args.probe, *probe_args], capture_output=True, text=True, timeout=30,
                                env=dict(os.environ, **(env or {})))
        print(f"  strata-health-probe {' '.join(probe_args)} -> {result.returncode}: "
              f"{(result.stdout + result.stderr).strip()}")
        return result

    # No preload: the server reports SERVING from the moment it logs "listening".
    server = subprocess.Popen([args.server, "--listen", "127.0.0.1:0", "--metrics-port", "-1", "--no-preload"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    address = None
    try:
        for line in server.stderr:
            match = re.search(r"event=listening address=(\S+)", line)
            if match:
                address = match.group(1)
                break
        if address is None:
            return report([f"strata-server exited ({server.wait()}) without listening"], "probe")
        if (r := probe(address)).returncode != 0 or "SERVING" not in r.stdout:
            errors.append("want exit 0 and SERVING from a ready server")
        if probe(address, "--service", "strata.v1.MapService").returncode != 0:
            errors.append("want exit 0 for strata.v1.MapService")
        if probe(address, "--service", "no.such.Service").returncode != 1:
            errors.append("want exit 1 for an unknown service")
        port = address.rsplit(":", 1)[1]
        if probe(env={"STRATA_LISTEN": f"0.0.0.0:{port}", "STRATA_HEALTH_ADDRESS": ""}).returncode != 0:
            errors.append("want exit 0 with the address taken from STRATA_LISTEN")
    finally:
        server.terminate()
        server.wait(timeout=30)
    if probe(address, "--timeout-s", "2").returncode != 1:
        errors.append("want exit 1 once the server is gone")
    if probe("--timeout-s", "zero").returncode != 3:
        errors.append("want exit 3 for a bad argument")
    return report(errors, "strata-health-probe")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.normpath(os.path.join(here, "..", ".."))
    for name in ("k8s", "broken"):
        p = sub.add_parser(name)
        p.add_argument("--kubectl")
        p.add_argument("--dir", default=os.path.join(repo, "deploy", "k8s"))
        p.add_argument("--schema", default=os.path.join(here, "k8s_schema.yaml"))
        if name == "broken":
            p.add_argument("--cases", default=os.path.join(here, "broken_cases.yaml"))
            p.add_argument("--compose", default=os.path.join(repo, "deploy", "compose.yaml"))
            p.add_argument("--prometheus", default=os.path.join(repo, "deploy", "prometheus", "prometheus.yml"))
    p = sub.add_parser("compose")
    p.add_argument("--compose", default=os.path.join(repo, "deploy", "compose.yaml"))
    p.add_argument("--prometheus", nargs="+", default=[
        os.path.join(repo, "deploy", "prometheus", "prometheus.yml"),
        os.path.join(repo, "deploy", "prometheus", "kubernetes-scrape.yml")])
    p = sub.add_parser("probe")
    p.add_argument("--probe", required=True)
    p.add_argument("--server", required=True)
    args = parser.parse_args()
    return {"k8s": cmd_k8s, "broken": cmd_broken, "compose": cmd_compose, "probe": cmd_probe}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
