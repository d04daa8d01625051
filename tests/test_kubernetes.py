"""deploy/kubernetes checked against the code, since no cluster is available here (issue 22
"Kubernetes"): the ConfigMap's rack loads with the daemon's loader, the ports are the ones the
rack binds, the probes name what the metrics endpoint answers (a daemon of that rack is started
and probed), the volumes mount where the image and the rack read."""

from __future__ import annotations

import json
import re
import tomllib
import urllib.request
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
import yaml
import zmq.auth

from vdevd import config
from vdevd.http_health import MetricsConfig, split_listen
from vdevd.security import CurveConfig
from vdevd.testing import DaemonThread

ROOT = Path(__file__).resolve().parents[1]
DEPLOY = ROOT / "deploy" / "kubernetes"


def manifests() -> dict[str, dict[str, Any]]:
    """Every object of deploy/kubernetes by kind."""
    objects: dict[str, dict[str, Any]] = {}
    for path in sorted(DEPLOY.glob("*.yaml")):
        for doc in yaml.safe_load_all(path.read_text()):
            if doc and doc.get("kind") != "Kustomization":
                assert doc["kind"] not in objects, f"two {doc['kind']}s"
                objects[doc["kind"]] = doc
    return objects


@pytest.fixture(scope="module")
def k8s() -> dict[str, dict[str, Any]]:
    return manifests()


def container(k8s: dict[str, dict[str, Any]]) -> dict[str, Any]:
    (c,) = k8s["Deployment"]["spec"]["template"]["spec"]["containers"]
    return c  # type: ignore[no-any-return]


def rack_text(k8s: dict[str, dict[str, Any]]) -> str:
    return str(k8s["ConfigMap"]["data"]["rack.toml"])


def entrypoint() -> list[str]:
    line = next(x for x in (ROOT / "docker" / "Dockerfile").read_text().splitlines()
                if x.startswith("ENTRYPOINT"))
    return list(json.loads(line.removeprefix("ENTRYPOINT")))


def mounts(k8s: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Each volume mount of the container by its path, with its volume."""
    volumes = {v["name"]: v for v in k8s["Deployment"]["spec"]["template"]["spec"]["volumes"]}
    return {m["mountPath"]: {**m, "volume": volumes[m["name"]]}
            for m in container(k8s)["volumeMounts"]}


def loaded_rack(k8s: dict[str, dict[str, Any]], tmp_path: Path) -> config.Config:
    """The ConfigMap's rack through `config.load`, its key paths moved to real keys made here
    under the names the Secret's volume gives them."""
    keys = tmp_path / "keys"
    (keys / "clients").mkdir(parents=True)
    zmq.auth.create_certificates(keys, "server")
    public, _ = zmq.auth.create_certificates(tmp_path, "client")
    Path(public).rename(keys / "clients" / "client.key")
    key_mount = next(p for p, m in mounts(k8s).items() if "secret" in m["volume"])
    path = tmp_path / "rack.toml"
    path.write_text(rack_text(k8s).replace(key_mount, str(keys)))
    return config.load(path)


def test_the_configmap_rack_loads_with_the_daemons_loader(k8s: dict[str, dict[str, Any]],
                                                           tmp_path: Path) -> None:
    cfg = loaded_rack(k8s, tmp_path)
    assert cfg.curve is not None and cfg.metrics is not None
    assert {c.type for c in cfg.cards} == {"generic-servo", "pmac-turbo"}


def test_the_volumes_mount_where_the_image_and_the_rack_read(k8s: dict[str, dict[str, Any]]) -> None:
    argv = entrypoint()
    config_path, state_dir = argv[argv.index("--config") + 1], argv[argv.index("--state-dir") + 1]
    m = mounts(k8s)
    assert m[config_path]["volume"]["configMap"]["name"] == k8s["ConfigMap"]["metadata"]["name"]
    assert m[config_path]["subPath"] in k8s["ConfigMap"]["data"]
    assert state_dir in m
    # the Secret's files land where [security] reads them
    security = tomllib.loads(rack_text(k8s))["security"]
    key_mount = next(p for p, x in m.items() if "secret" in x["volume"])
    secret = next(x["volume"]["secret"] for x in m.values() if "secret" in x["volume"])
    assert secret["secretName"] == k8s["Secret"]["metadata"]["name"]
    files = {f"{key_mount}/{item['path']}": item["key"] for item in secret["items"]}
    assert files[security["server_secret_key"]] in k8s["Secret"]["stringData"]
    assert any(f.startswith(security["client_keys_dir"] + "/") for f in files)
    assert set(files.values()) == set(k8s["Secret"]["stringData"])


def test_ports_are_the_ones_the_rack_binds(k8s: dict[str, dict[str, Any]]) -> None:
    rack = tomllib.loads(rack_text(k8s))
    bound = {
        int(rack["server"]["endpoint"].rsplit(":", 1)[1]),
        int(rack["server"]["events"].rsplit(":", 1)[1]),
        split_listen(rack["metrics"]["listen"])[1],
        *(int(c["ethernet"].rsplit(":", 1)[1]) for c in rack["card"] if c.get("ethernet")),
    }
    ports = {p["name"]: p["containerPort"] for p in container(k8s)["ports"]}
    assert set(ports.values()) == bound
    service = k8s["Service"]["spec"]
    assert {p["targetPort"] for p in service["ports"]} == set(ports)
    assert {p["port"] for p in service["ports"]} == bound
    labels = k8s["Deployment"]["spec"]["template"]["metadata"]["labels"]
    assert service["selector"].items() <= labels.items()
    assert k8s["Deployment"]["spec"]["selector"]["matchLabels"].items() <= labels.items()
    assert k8s["Deployment"]["spec"]["replicas"] == 1  # one rack per pod
    annotations = k8s["Deployment"]["spec"]["template"]["metadata"]["annotations"]
    assert int(annotations["prometheus.io/port"]) == split_listen(rack["metrics"]["listen"])[1]


def test_probes_ask_what_the_metrics_endpoint_answers(k8s: dict[str, dict[str, Any]],
                                                       tmp_path: Path) -> None:
    c = container(k8s)
    ports = {p["name"]: p["containerPort"] for p in c["ports"]}
    probes = {kind: c[kind]["httpGet"] for kind in ("livenessProbe", "readinessProbe",
                                                    "startupProbe")}
    assert probes["livenessProbe"]["path"] == "/healthz"
    assert probes["readinessProbe"]["path"] == probes["startupProbe"]["path"] == "/readyz"
    cfg = loaded_rack(k8s, tmp_path)
    assert cfg.metrics is not None
    for probe in probes.values():
        assert ports[probe["port"]] == split_listen(cfg.metrics.listen)[1]
    assert set(c["resources"]["requests"]) == {"cpu", "memory"}
    assert re.fullmatch(r"\d+Mi", c["resources"]["limits"]["memory"])
    # the rack of the ConfigMap, served here on free ports, answers the probes' paths
    cfg.endpoint = cfg.events = "tcp://127.0.0.1:*"
    cfg.metrics = replace(cfg.metrics, listen="127.0.0.1:0")
    cfg.cards = [replace(s, options={**s.options, "ethernet": "tcp://127.0.0.1:0"})
                 if s.options.get("ethernet") else s for s in cfg.cards]
    assert isinstance(cfg.curve, CurveConfig) and isinstance(cfg.metrics, MetricsConfig)
    with DaemonThread(cfg) as d:
        assert d.health is not None
        for probe in probes.values():
            with urllib.request.urlopen(d.health.url + probe["path"], timeout=10) as r:
                assert r.status == 200
