"""gonio: a Python client of goniod, the gonio spectrophotometer service.

    import gonio
    with gonio.connect("tcp://127.0.0.1:7700", token_file="admin.token") as client:
        scan = client.scan.submit(sample="paint", grids="in=45;out=-30:80:2")
        client.scan.wait(scan=scan["id"])
        frame = client.scan.points(scan=scan["id"]).to_frame()

Every method of goniod's API (proto/openrpc.json) is `client.<area>.<verb>(**params)`;
errors are gonio.RpcError subclasses carrying code, errc and field (gonio.PlanRejected,
gonio.Unauthorized, gonio.InvalidParams, ...). The standard library suffices; numpy and
pandas are used by .to_arrays() and .to_frame().
"""
from .client import OMIT, Client, connect, default_state_dir
from .errors import *  # noqa: F401,F403 — the classes made from x-error-codes
from .errors import __all__ as _error_names
from .results import Export, FitResult, Points
from .schema import document, methods
from .subscription import Notification, Subscription
from .waiting import bar_text

__version__ = "0.2.0"
__all__ = ["Client", "connect", "default_state_dir", "OMIT", "Points", "Export", "FitResult",
           "Subscription", "Notification", "bar_text", "document", "methods", *_error_names]
