"""Submit a scan, wait for it, plot measured against predicted β: python3 submit_wait_plot.py"""
import gonio
import matplotlib.pyplot as plt

with gonio.connect() as client:  # the state dir's socket; or gonio.connect("tcp://HOST:7700", token_file=...)
    scan = client.scan.submit(sample="paint", grids="in=45;out=-30:80:2", wavelengths="400:700:10")
    client.scan.wait(scan=scan["id"])
    frame = client.scan.points(scan=scan["id"]).to_frame()

at = frame[frame.wavelength_nm == 550]
plt.errorbar(at.theta_r, at.measured, yerr=at.measured_u, fmt=".", label="measured")
plt.errorbar(at.theta_r, at.predicted, yerr=at.predicted_se, label="twin")
plt.xlabel("θr (deg)"), plt.ylabel("β at 550 nm"), plt.legend()
plt.savefig("scan.png")
