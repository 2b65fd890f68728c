"""deploy/k8s, offline: every manifest validates against the Kubernetes API schemas
(kubernetes-validate, strict: unknown fields are errors), and the manifests agree with each
other, with the image and with the app (probes on real routes)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import kubernetes_validate
import pytest
import yaml

from service.main import create_app
from service.settings import Settings
from tests.deploy.routes import serves
from tests.deploy.test_image_files import instructions

ROOT = Path(__file__).resolve().parents[2]
K8S = ROOT / "deploy" / "k8s"
# The oldest Kubernetes release still commonly run, and the newest the package knows.
VERSIONS = ["1.29.0", kubernetes_validate.latest_version()]


def _documents() -> list[tuple[str, dict[str, Any]]]:
    kustomization = yaml.safe_load((K8S / "kustomization.yaml").read_text())
    docs = []
    for name in kustomization["resources"]:
        docs += [(name, doc) for doc in yaml.safe_load_all((K8S / name).read_text()) if doc]
    return docs


DOCUMENTS = _documents()


def _kind(kind: str) -> dict[str, Any]:
    found = [doc for _, doc in DOCUMENTS if doc["kind"] == kind]
    assert len(found) == 1, kind
    return found[0]


def test_kustomization_lists_every_manifest():
    listed = set(yaml.safe_load((K8S / "kustomization.yaml").read_text())["resources"])
    on_disk = {p.name for p in K8S.glob("*.yaml")} - {"kustomization.yaml"}
    assert listed == on_disk


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("name,doc", DOCUMENTS, ids=[f"{n}:{d['kind']}" for n, d in DOCUMENTS])
def test_manifest_validates(name, doc, version):
    kubernetes_validate.validate(doc, version, strict=True)


def test_validation_catches_mistakes():
    deployment = copy.deepcopy(_kind("Deployment"))
    deployment["spec"]["replicas"] = "two"
    with pytest.raises(kubernetes_validate.ValidationError):
        kubernetes_validate.validate(deployment, VERSIONS[-1], strict=True)
    deployment = copy.deepcopy(_kind("Deployment"))
    deployment["spec"]["template"]["spec"]["containers"][0]["readinessProbe"]["httpGett"] = {}
    with pytest.raises(kubernetes_validate.ValidationError):
        kubernetes_validate.validate(deployment, VERSIONS[-1], strict=True)


@pytest.fixture(scope="module")
def pod() -> dict[str, Any]:
    return _kind("Deployment")["spec"]["template"]["spec"]


@pytest.fixture(scope="module")
def container(pod) -> dict[str, Any]:
    (only,) = pod["containers"]
    return only


def _env(container) -> dict[str, Any]:
    return {e["name"]: e.get("value", e.get("valueFrom")) for e in container["env"]}


def test_probes_point_at_real_routes_on_the_served_port(container):
    app = create_app()
    ports = {p["name"]: p["containerPort"] for p in container["ports"]}
    expected = {"readinessProbe": "/health/ready", "livenessProbe": "/health/live"}
    for probe, path in expected.items():
        get = container[probe]["httpGet"]
        assert get["path"] == path and serves(app, "GET", get["path"]), probe
        assert ports[get["port"]] == 8000
    assert not serves(app, "GET", "/healthz")  # the check itself can fail


def test_deployment_runs_several_non_root_replicas_of_the_image(pod, container):
    deployment = _kind("Deployment")
    assert deployment["spec"]["replicas"] >= 2
    dockerfile = dict(instructions((ROOT / "Dockerfile").read_text()))
    uid = int(dockerfile["USER"].split(":")[0])
    security = pod["securityContext"]
    assert security["runAsNonRoot"] is True and security["runAsUser"] == uid != 0
    assert container["securityContext"]["allowPrivilegeEscalation"] is False
    assert container["ports"][0]["containerPort"] == int(dockerfile["EXPOSE"])
    labels = deployment["spec"]["template"]["metadata"]["labels"]
    assert deployment["spec"]["selector"]["matchLabels"].items() <= labels.items()
    for kind in ("Service", "PodDisruptionBudget"):
        doc = _kind(kind)
        selector = doc["spec"]["selector"]
        selector = selector.get("matchLabels", selector)
        assert selector.items() <= labels.items(), kind


def test_resources_are_requested_and_limited(container):
    resources = container["resources"]
    for key in ("cpu", "memory"):
        assert key in resources["requests"] and key in resources["limits"]

    def mib(quantity: str) -> float:
        units = {"Mi": 1, "Gi": 1024}
        return float(quantity[:-2]) * units[quantity[-2:]]

    assert mib(resources["requests"]["memory"]) <= mib(resources["limits"]["memory"])
    env = _env(container)
    assert env["ROBODYN_WORKERS"] == "1"  # one process per pod: its /metrics is the pod's
    assert int(env["ROBODYN_MAX_BATCH"]) <= Settings().max_batch  # caps one answer's memory
    # answers held for clients that do not read: at most a quarter of the pod's memory
    held = int(env["ROBODYN_MAX_ANSWER_BYTES_IN_FLIGHT"])
    assert held <= mib(resources["limits"]["memory"]) * 2**20 / 4


def test_every_replica_shares_one_read_write_many_volume_as_data_dir(pod, container):
    claim = _kind("PersistentVolumeClaim")
    assert claim["spec"]["accessModes"] == ["ReadWriteMany"]
    volumes = {v["name"]: v for v in pod["volumes"]}
    mounts = {m["mountPath"]: m["name"] for m in container["volumeMounts"]}
    data_dir = _env(container)["ROBODYN_DATA_DIR"]
    volume = volumes[mounts[data_dir]]
    assert volume["persistentVolumeClaim"]["claimName"] == claim["metadata"]["name"]
    # A read-only root file system needs a writable /tmp (multiprocessing's forkserver).
    if container["securityContext"].get("readOnlyRootFilesystem"):
        assert "emptyDir" in volumes[mounts["/tmp"]]


def test_api_keys_come_from_the_secret(container):
    secret = _kind("Secret")
    ref = _env(container)["ROBODYN_API_KEYS"]["secretKeyRef"]
    assert ref["name"] == secret["metadata"]["name"]
    assert ref["key"] in secret.get("stringData", secret.get("data", {}))


def test_graceful_termination_outlasts_the_longest_request(pod, container):
    env = _env(container)
    pre_stop = container["lifecycle"]["preStop"]["exec"]["command"]
    assert pre_stop[0] == "sleep"
    server_drain = 30  # uvicorn's timeout_graceful_shutdown in `python -m service`
    main_source = (ROOT / "service" / "__main__.py").read_text()
    assert f"timeout_graceful_shutdown={server_drain}" in main_source
    longest_request = max(
        float(env["ROBODYN_BUILD_TIMEOUT_S"]),  # an upload's model build
        float(env["ROBODYN_EQUATIONS_TIMEOUT_S"]),
    )  # a first derivation
    grace = pod["terminationGracePeriodSeconds"]
    assert grace > int(pre_stop[1]) + max(server_drain, longest_request)


def test_autoscaler_and_disruption_budget_keep_replicas_serving():
    deployment = _kind("Deployment")
    hpa = _kind("HorizontalPodAutoscaler")
    target = hpa["spec"]["scaleTargetRef"]
    assert (target["kind"], target["name"]) == ("Deployment", deployment["metadata"]["name"])
    assert (
        hpa["spec"]["minReplicas"] >= 2 and hpa["spec"]["maxReplicas"] > hpa["spec"]["minReplicas"]
    )
    (metric,) = hpa["spec"]["metrics"]
    assert metric["type"] == "Resource" and metric["resource"]["name"] == "cpu"
    pdb = _kind("PodDisruptionBudget")
    assert 1 <= pdb["spec"]["minAvailable"] < hpa["spec"]["minReplicas"]


def _merged_by_name(base: list[dict[str, Any]], patch: list[dict[str, Any]]) -> list[dict]:
    """Lists of named objects merged as kustomize's strategic merge does (by `name`)."""
    merged = {item["name"]: copy.deepcopy(item) for item in base}
    for item in patch:
        if item["name"] not in merged:
            merged[item["name"]] = copy.deepcopy(item)
            continue
        target = merged[item["name"]]
        for key, value in item.items():
            if isinstance(value, list) and value and isinstance(value[0], dict):
                key_name = "name"
                target[key] = (
                    _merged_by_name(target.get(key, []), value)
                    if all(key_name in v for v in value)
                    else value
                )
            elif key != "name":
                target[key] = value
    return list(merged.values())


def test_the_colocated_overlay_shares_the_socket_with_a_sidecar():
    """deploy/k8s/colocated: the base Deployment with a client container that reaches the
    server through a Unix socket in an in-memory emptyDir both mount, as the same user."""
    overlay = K8S / "colocated"
    kustomization = yaml.safe_load((overlay / "kustomization.yaml").read_text())
    assert kustomization["resources"] == ["../"]
    (patch_file,) = [p["path"] for p in kustomization["patches"]]
    patch = yaml.safe_load((overlay / patch_file).read_text())
    deployment = copy.deepcopy(_kind("Deployment"))
    assert patch["kind"] == "Deployment" and patch["metadata"]["name"] == "robodyn"
    pod, patched = deployment["spec"]["template"]["spec"], patch["spec"]["template"]["spec"]
    pod["containers"] = _merged_by_name(pod["containers"], patched["containers"])
    pod["volumes"] = _merged_by_name(pod["volumes"], patched["volumes"])
    for version in VERSIONS:
        kubernetes_validate.validate(deployment, version, strict=True)
    server, client = pod["containers"]
    volume = next(v for v in pod["volumes"] if v["name"] == patched["volumes"][0]["name"])
    assert volume["emptyDir"]["medium"] == "Memory"  # tmpfs: the segments are memory
    mounts = [
        {m["name"]: m["mountPath"] for m in c["volumeMounts"]}[volume["name"]]
        for c in (server, client)
    ]
    assert mounts[0] == mounts[1]
    socket_path = _env(server)["ROBODYN_UNIX_SOCKET"]
    assert socket_path.startswith(mounts[0] + "/")
    assert _env(client)["ROBODYN_URL"] == "unix://" + socket_path
    assert pod["securityContext"]["runAsUser"] == 10001  # one user: the socket is 0600
    assert Settings(unix_socket=socket_path).unix_socket_mode_bits() == 0o600
    assert _env(server)["ROBODYN_DATA_DIR"] == "/data"  # the base's settings are kept
