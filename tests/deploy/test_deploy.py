"""deploy/kubernetes.yaml, the department setup of :ref:`serving-many`: consistent with itself and with the image.

No cluster here, so the manifest is checked as data: every reference resolves (selector → labels, ingress → service
→ named container port), the sticky-session annotations are there (a page's websocket must reach the replica that
holds its session), the probes use /liveness, the pod runs as the container hardening expects (non-root in group 0,
read-only root file system with a writable /tmp), and the allowed origin is the ingress's host name.
"""

from __future__ import annotations

import yaml
from _serving import REPO
from test_dockerfile import final_stage

MANIFEST = REPO / "deploy" / "kubernetes.yaml"


def documents() -> dict[str, dict]:
    docs = [d for d in yaml.safe_load_all(MANIFEST.read_text()) if d]
    assert all({"apiVersion", "kind", "metadata"} <= set(d) for d in docs)
    return {d["kind"]: d for d in docs}


def test_references_resolve_and_sessions_are_sticky():
    docs = documents()
    deployment, service, ingress = docs["Deployment"], docs["Service"], docs["Ingress"]
    pod = deployment["spec"]["template"]
    assert deployment["spec"]["replicas"] >= 2
    assert deployment["spec"]["selector"]["matchLabels"].items() <= pod["metadata"]["labels"].items()
    assert service["spec"]["selector"].items() <= pod["metadata"]["labels"].items()
    (container,) = pod["spec"]["containers"]
    ports = {p["name"]: p["containerPort"] for p in container["ports"]}
    assert ports[service["spec"]["ports"][0]["targetPort"]] == int(dict(final_stage())["EXPOSE"])  # 5006
    backend = ingress["spec"]["rules"][0]["http"]["paths"][0]["backend"]["service"]
    assert backend["name"] == service["metadata"]["name"]
    assert backend["port"]["name"] == service["spec"]["ports"][0]["name"]
    notes = ingress["metadata"]["annotations"]
    assert notes["nginx.ingress.kubernetes.io/affinity"] == "cookie"
    assert int(notes["nginx.ingress.kubernetes.io/proxy-read-timeout"]) >= 600  # a lesson's websocket stays open


def test_pods_run_as_the_image_is_hardened_for_and_probe_liveness():
    docs = documents()
    spec = docs["Deployment"]["spec"]["template"]["spec"]
    (container,) = spec["containers"]
    assert spec["securityContext"]["runAsNonRoot"] and spec["securityContext"]["runAsGroup"] == 0
    assert container["securityContext"]["readOnlyRootFilesystem"] is True
    assert container["securityContext"]["allowPrivilegeEscalation"] is False
    mounts = {m["mountPath"]: m["name"] for m in container["volumeMounts"]}
    volumes = {v["name"]: v for v in spec["volumes"]}
    assert "emptyDir" in volumes[mounts["/tmp"]]  # the kernels' cache falls back to /tmp (isl_core.kernels)
    for probe in ("readinessProbe", "livenessProbe"):
        assert container[probe]["httpGet"]["path"] == "/liveness"
        # the loop's measured stalls under a class reach seconds: kubernetes' default 1 s timeout would take a
        # busy replica out of the service (or restart it) during a lesson
        assert container[probe].get("timeoutSeconds", 1) >= 5, probe
    env = {e["name"]: e["value"] for e in container["env"]}
    assert env["ISL_ALLOWED_ORIGINS"] == docs["Ingress"]["spec"]["rules"][0]["host"]
    assert container["resources"]["requests"]["cpu"]


def test_one_process_per_requested_core_stopped_within_the_grace_period():
    """The pod forks one server process per core it requests (the default would follow a CPU limit, or without one
    the node's cores), and the server ends all of them before Kubernetes would kill the pod."""
    from app.serving.workers import GRACE_S

    spec = documents()["Deployment"]["spec"]["template"]["spec"]
    (container,) = spec["containers"]
    env = {e["name"]: e["value"] for e in container["env"]}
    assert int(env["ISL_NUM_PROCS"]) == int(container["resources"]["requests"]["cpu"])
    assert spec["terminationGracePeriodSeconds"] > GRACE_S + 5
