"""Certificates for Zenoh TLS made with openssl: a certificate authority, a server certificate for the
bridge's address and client certificates for mutual TLS.

For tests, the benchmark and the README's recipe; a real deployment may use any CA. Keys are EC P-256
(PKCS#8 PEM), certificates X.509 v3 with the subjectAltName rustls (Zenoh's TLS) insists on.
"""

from __future__ import annotations

import subprocess
from dataclasses import dataclass
from pathlib import Path

from mrs_nav.errors import InvalidInputError

DAYS = 30


@dataclass(frozen=True)
class KeyPair:
    """A PEM certificate and its private key."""

    cert: Path
    key: Path


def _openssl(*args: str) -> None:
    try:
        subprocess.run(["openssl", *args], check=True, capture_output=True, text=True)
    except FileNotFoundError:
        raise InvalidInputError("openssl is not installed (apt-get install openssl)") from None
    except subprocess.CalledProcessError as err:
        raise InvalidInputError(f"openssl {args[0]} failed: {err.stderr.strip()}") from None


def make_ca(directory: Path, name: str = "mrs_nav-ca") -> KeyPair:
    """A self-signed certificate authority ``<name>.pem`` / ``<name>.key`` in ``directory``."""
    directory.mkdir(parents=True, exist_ok=True)
    pair = KeyPair(directory / f"{name}.pem", directory / f"{name}.key")
    _openssl(
        "req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
        "-keyout", str(pair.key), "-out", str(pair.cert), "-days", str(DAYS), "-subj", f"/CN={name}",
        "-addext", "basicConstraints=critical,CA:TRUE", "-addext", "keyUsage=critical,keyCertSign,cRLSign",
    )  # fmt: skip
    return pair


def make_cert(ca: KeyPair, directory: Path, name: str, hosts: tuple[str, ...] = ()) -> KeyPair:
    """A certificate with common name ``name`` signed by ``ca``; ``hosts`` (IP addresses or DNS names) go in
    its subjectAltName, which a server certificate needs and a client certificate may leave empty."""
    pair = KeyPair(directory / f"{name}.pem", directory / f"{name}.key")
    request = directory / f"{name}.csr"
    _openssl(
        "req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
        "-keyout", str(pair.key), "-out", str(request), "-subj", f"/CN={name}",
    )  # fmt: skip
    alt = ",".join(f"IP:{h}" if h.replace(".", "").isdigit() or ":" in h else f"DNS:{h}" for h in hosts)
    extensions = directory / f"{name}.ext"
    extensions.write_text(
        "basicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth,clientAuth\n"
        + (f"subjectAltName={alt}\n" if alt else ""),
        encoding="utf-8",
    )
    _openssl(
        "x509", "-req", "-in", str(request), "-CA", str(ca.cert), "-CAkey", str(ca.key), "-CAcreateserial",
        "-out", str(pair.cert), "-days", str(DAYS), "-extfile", str(extensions),
    )  # fmt: skip
    return pair
