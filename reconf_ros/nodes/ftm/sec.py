"""SEC of paper 000 §5.3.2: the client side ciphers and signs each request, the server side
deciphers and checks it, and the reply comes back the same way (docs/ftm.md#running).

Keys: the certification authority node (`certify`) provisions a key directory (RECONF_FTM_KEYS,
by default `ftm-keys` in its working directory) with its own Ed25519 key and, for each party
(`client`, `server`), an Ed25519 signing key and an X25519 key, each party's public keys
certified by the CA; it publishes the certificates on its topic. A party reads its own private
keys and the CA's public key (the trust anchor) from the directory, and sends its certificate
with every message, so the receiver checks the sender against the CA before it trusts it.
A message is ChaCha20-Poly1305 under a key both sides derive (X25519, then HKDF-SHA256), with
the request id as associated data, signed by the sender (Ed25519) over id, nonce and ciphertext.
A message that fails any check is dropped and counted; the proxy sends the request again.
"""
from __future__ import annotations

import base64
import json
import os
from pathlib import Path
from typing import Any, Optional

from cryptography.exceptions import InvalidSignature, InvalidTag
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey, Ed25519PublicKey
from cryptography.hazmat.primitives.asymmetric.x25519 import X25519PrivateKey, X25519PublicKey
from cryptography.hazmat.primitives.ciphers.aead import ChaCha20Poly1305
from cryptography.hazmat.primitives.kdf.hkdf import HKDF

from reconf_dsl.ir import System

from ..api import Component
from .wire import Ports, pack, unpack

__all__ = ["CertificationAuthority", "ClientCipher", "ClientDecipher", "ServerDecipher", "ServerCipher",
           "Keys", "provision", "PARTIES"]

PARTIES = ("client", "server")
RAW = serialization.Encoding.Raw, serialization.PublicFormat.Raw


def _b64(data: bytes) -> str:
    return base64.b64encode(data).decode()


def _unb64(text: str) -> bytes:
    return base64.b64decode(text.encode())


def key_dir() -> Path:
    return Path(os.environ.get("RECONF_FTM_KEYS", "ftm-keys"))


def _private(path: Path, kind: type) -> Any:
    key = serialization.load_pem_private_key(path.read_bytes(), password=None)
    assert isinstance(key, kind)
    return key


def _write_private(path: Path, key: Any) -> None:
    path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                       serialization.NoEncryption()))
    path.chmod(0o600)


def provision(directory: Path) -> dict[str, Any]:
    """Make the CA key and every party's keys and certificates in `directory` (once); the
    certificate bundle."""
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    bundle_path = directory / "certificates.json"
    if bundle_path.exists():
        return dict(json.loads(bundle_path.read_text()))
    ca = Ed25519PrivateKey.generate()
    _write_private(directory / "ca.key", ca)
    certs = {}
    for party in PARTIES:
        sign, box = Ed25519PrivateKey.generate(), X25519PrivateKey.generate()
        _write_private(directory / f"{party}.sign.key", sign)
        _write_private(directory / f"{party}.box.key", box)
        body = {"party": party, "sign": _b64(sign.public_key().public_bytes(*RAW)),
                "box": _b64(box.public_key().public_bytes(*RAW))}
        certs[party] = {**body, "ca_sig": _b64(ca.sign(pack(body).encode()))}
    bundle = {"ca": _b64(ca.public_key().public_bytes(*RAW)), "certificates": certs}
    tmp = bundle_path.with_suffix(".tmp")
    tmp.write_text(json.dumps(bundle))
    tmp.replace(bundle_path)       # parties wait for this file: it appears whole
    return bundle


class Keys:
    """One party's private keys and the trust anchor, read from the key directory when first needed."""

    def __init__(self, party: str) -> None:
        self.party = party
        self.ready = False
        self.rejected = 0

    def load(self) -> bool:
        if not self.ready:
            d = key_dir()
            bundle_path = d / "certificates.json"
            if not bundle_path.exists():
                return False
            bundle = json.loads(bundle_path.read_text())
            self.ca = Ed25519PublicKey.from_public_bytes(_unb64(bundle["ca"]))
            self.certificates: dict[str, Any] = bundle["certificates"]
            self.cert = self.certificates[self.party]
            self.sign_key = _private(d / f"{self.party}.sign.key", Ed25519PrivateKey)
            self.box_key = _private(d / f"{self.party}.box.key", X25519PrivateKey)
            self.ready = True
        return True

    def trusted(self, cert: dict[str, Any], party: str) -> bool:
        body = {k: cert.get(k) for k in ("party", "sign", "box")}
        try:
            self.ca.verify(_unb64(cert["ca_sig"]), pack(body).encode())
        except (InvalidSignature, KeyError, ValueError, TypeError):
            return False
        return cert.get("party") == party

    def _aead(self, peer: dict[str, Any]) -> ChaCha20Poly1305:
        shared = self.box_key.exchange(X25519PublicKey.from_public_bytes(_unb64(peer["box"])))
        key = HKDF(algorithm=hashes.SHA256(), length=32, salt=None, info=b"reconf-ftm-sec").derive(shared)
        return ChaCha20Poly1305(key)

    def seal(self, rid: str, doc: Any, peer: dict[str, Any]) -> dict[str, Any]:
        nonce = os.urandom(12)
        ct = self._aead(peer).encrypt(nonce, pack({"doc": doc}).encode(), rid.encode())
        sig = self.sign_key.sign(rid.encode() + nonce + ct)
        return {"nonce": _b64(nonce), "ct": _b64(ct), "sig": _b64(sig), "cert": self.cert}

    def open(self, rid: str, sealed: Any, party: str) -> tuple[Optional[Any], Optional[dict[str, Any]]]:
        """(the document, the sender's certificate), or (None, None) when any check fails."""
        try:
            cert = sealed["cert"]
            if not self.trusted(cert, party):
                raise InvalidSignature("certificate")
            nonce, ct = _unb64(sealed["nonce"]), _unb64(sealed["ct"])
            Ed25519PublicKey.from_public_bytes(_unb64(cert["sign"])).verify(_unb64(sealed["sig"]),
                                                                             rid.encode() + nonce + ct)
            doc = json.loads(self._aead(cert).decrypt(nonce, ct, rid.encode()))["doc"]
            return doc, cert
        except (InvalidSignature, InvalidTag, KeyError, ValueError, TypeError):
            self.rejected += 1
            return None, None


class CertificationAuthority:
    """Provisions the key directory once it runs (describing or building the node writes nothing)
    and publishes the certificates (once a second, durable)."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        self.bundle: Optional[dict[str, Any]] = None
        comp.create_timer(1, self.publish)

    def publish(self) -> None:
        if self.bundle is None:
            self.bundle = provision(key_dir())
        self.p.send("cert", self.bundle)


class _Sec:
    party = "client"
    peer = "server"

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        self.p = ports
        self.keys = Keys(self.party)
        self.bundle: Optional[dict[str, Any]] = None
        if ports.has("cert"):
            ports.input("cert").on_message(self.on_cert)

    def on_cert(self, msg: Any) -> None:
        doc = unpack(msg, need="certificates")
        if doc is not None:
            self.bundle = doc

    def peer_cert(self) -> Optional[dict[str, Any]]:
        if self.bundle is None or not self.keys.load():
            return None
        cert = self.bundle["certificates"].get(self.peer)
        return cert if cert is not None and self.keys.trusted(cert, self.peer) else None

    def log_rejected(self, rid: str) -> None:
        self.p.comp.node.get_logger().warning(f"{rid}: a message failed its checks and is dropped "
                                              f"({self.keys.rejected} so far)")


class ClientCipher(_Sec):
    """Client side, before: cipher and sign the request for the server."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        super().__init__(comp, ports, system)
        ports.input("from_proxy").on_message(self.on_request)

    def on_request(self, msg: Any) -> None:
        req, peer = unpack(msg, need="rid"), self.peer_cert()
        if req is None or peer is None:
            return          # no certificate yet: the proxy sends the request again
        # the id and the proxy's floor stay in clear for the server's protocol; the request is
        # sealed, and bound to its id
        self.p.send("to_server", {"rid": req["rid"], "floor": req.get("floor", 0),
                                  "sealed": self.keys.seal(req["rid"], req, peer)})


class ServerDecipher(_Sec):
    """Server side, before: check and decipher the request."""
    party, peer = "server", "client"

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        super().__init__(comp, ports, system)
        ports.input("from_protocol").on_message(self.on_request)

    def on_request(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None or not self.keys.load():
            return
        req, cert = self.keys.open(doc["rid"], doc.get("sealed"), self.peer)
        if req is None or req.get("rid") != doc["rid"]:
            self.log_rejected(doc["rid"])
            # the refusal goes down the layer and back to its protocol, which then forgets the
            # request (the proxy sends a genuine one again); nothing inside runs it
            self.p.send("to_proceed", {"rid": doc["rid"], "rejected": "failed the checks of SEC"})
            return
        self.p.send("to_proceed", req)


class ServerCipher(_Sec):
    """Server side, after: cipher and sign the reply for the client (its provisioned certificate)."""
    party, peer = "server", "client"

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        super().__init__(comp, ports, system)
        ports.input("from_proceed").on_message(self.on_result)

    def on_result(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None or not self.keys.load():
            return
        if "rejected" in doc:
            self.p.send("to_protocol", {"rid": doc["rid"], "rejected": doc["rejected"]})
            return
        peer = self.keys.certificates.get(self.peer)
        if peer is None or not self.keys.trusted(peer, self.peer):
            return
        self.p.send("to_protocol", {"rid": doc["rid"], "reply": self.keys.seal(doc["rid"], doc.get("reply"), peer)})


class ClientDecipher(_Sec):
    """Client side, after: check and decipher the reply for the proxy."""

    def __init__(self, comp: Component, ports: Ports, system: System) -> None:
        super().__init__(comp, ports, system)
        ports.input("from_server").on_message(self.on_reply)

    def on_reply(self, msg: Any) -> None:
        doc = unpack(msg, need="rid")
        if doc is None or not self.keys.load():
            return
        if "takeover" in doc:       # a backup's notice: it carries nothing but a prompt to re-send
            self.p.send("to_proxy", {"rid": "", "takeover": str(doc["takeover"])})
            return
        reply, _ = self.keys.open(doc["rid"], doc.get("reply"), self.peer)
        if reply is None:
            return self.log_rejected(doc["rid"])
        self.p.send("to_proxy", {"rid": doc["rid"], "reply": reply})
