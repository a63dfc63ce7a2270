"""The client's TLS (tls://, https://): goniod's certificate verified against ca= and its
name against the host, as gonioctl --ca does. The server here is a TLS endpoint made with
Python's ssl module and certificates made by the openssl command: what is under test is the
client's verification, which needs a real TLS handshake, not goniod's JSON-RPC."""
import json
import shutil
import socket
import ssl
import subprocess
import threading

import pytest

import gonio

pytestmark = pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")


def openssl(*args, cwd):
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True)


@pytest.fixture(scope="module")
def pki(tmp_path_factory):
    """A lab CA, a server certificate it signed for localhost and 127.0.0.1, another CA."""
    d = tmp_path_factory.mktemp("pki")
    for ca in ("ca", "other"):
        openssl("req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
                "-keyout", f"{ca}.key", "-out", f"{ca}.crt", "-days", "2", "-subj", f"/CN=gonio test {ca}", cwd=d)
    openssl("req", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
            "-keyout", "server.key", "-out", "server.csr", "-subj", "/CN=localhost", cwd=d)
    (d / "san.ext").write_text("subjectAltName=DNS:localhost,IP:127.0.0.1\n")
    openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", "server.crt", "-days", "2", "-extfile", "san.ext", cwd=d)
    (d / "elsewhere.ext").write_text("subjectAltName=DNS:goniod.elsewhere.example\n")
    openssl("x509", "-req", "-in", "server.csr", "-CA", "ca.crt", "-CAkey", "ca.key", "-CAcreateserial",
            "-out", "elsewhere.crt", "-days", "2", "-extfile", "elsewhere.ext", cwd=d)
    return d


@pytest.fixture(params=["server"])
def server(pki, request):
    """NDJSON over TLS answering every request with {method}; auth.login with a principal.
    Its certificate: pki/<param>.crt."""
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    ctx.load_cert_chain(pki / f"{request.param}.crt", pki / "server.key")
    lsock = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve():
        lsock.settimeout(0.2)
        while not stop.is_set():
            try:
                raw, _ = lsock.accept()
            except socket.timeout:
                continue
            try:
                conn = ctx.wrap_socket(raw, server_side=True)
            except (ssl.SSLError, OSError):
                raw.close()
                continue
            with conn, conn.makefile("rb") as lines:
                for line in lines:
                    m = json.loads(line)
                    result = ({"name": "lab", "role": "technician", "transport": "tcp"}
                              if m["method"] == "auth.login" else {"method": m["method"]})
                    conn.sendall((json.dumps({"jsonrpc": "2.0", "id": m["id"], "result": result}) + "\n").encode())
    t = threading.Thread(target=serve, daemon=True)
    t.start()
    yield lsock.getsockname()[1]
    stop.set()
    t.join()
    lsock.close()


def test_a_certificate_signed_by_the_given_ca_is_trusted(pki, server):
    for host in ("localhost", "127.0.0.1"):
        with gonio.connect(f"tls://{host}:{server}", token="t", ca=str(pki / "ca.crt")) as c:
            assert c.principal["name"] == "lab"
            assert c.system.info() == {"method": "system.info"}


def test_another_ca_or_none_is_refused_with_a_clear_error(pki, server):
    with pytest.raises(gonio.TlsError, match="not trusted.*ca="):
        gonio.connect(f"tls://127.0.0.1:{server}", token="t", ca=str(pki / "other.crt"))
    with pytest.raises(gonio.TlsError):
        gonio.connect(f"tls://127.0.0.1:{server}", token="t")  # the system's CAs do not know it


@pytest.mark.parametrize("server", ["elsewhere"], indirect=True)
def test_the_name_must_match_the_host(pki, server):
    # signed by the trusted CA, but for goniod.elsewhere.example, not 127.0.0.1
    with pytest.raises(gonio.TlsError, match="not trusted.*(mismatch|match)"):
        gonio.connect(f"tls://127.0.0.1:{server}", token="t", ca=str(pki / "ca.crt"))


def test_goniod_over_tls_and_https_verified_by_ca(pki):
    """A real goniod with tls:// and https:// listeners: the client verifies it against ca=,
    and calls over NDJSON/TLS and over HTTPS."""
    from goniod_process import Goniod
    (pki / "server.key").chmod(0o600)
    tls = f'[server.tls]\ncert = "{pki / "server.crt"}"\nkey = "{pki / "server.key"}"\n'
    d = Goniod(fixed_ports=False, extra=tls, listen_more=("tls://127.0.0.1:0", "https://127.0.0.1:0"))
    try:
        for scheme, transport in (("tls", "tls"), ("https", "https")):
            with gonio.connect(d.url(scheme), token_file=d.token_file, ca=str(pki / "ca.crt")) as c:
                assert c.auth.whoami() == {"name": "admin", "role": "admin", "transport": transport}
        with pytest.raises(gonio.TlsError, match="not trusted"):
            gonio.connect(d.url("tls"), token_file=d.token_file, ca=str(pki / "other.crt"))
    finally:
        d.close()
