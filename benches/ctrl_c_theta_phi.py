"""How long Ctrl-C takes to stop theta-phi on a million vertices (issue 13,
item 2): a child process embeds a 1M-vertex bumpy_blob, the parent sends
SIGINT at each delay given (seconds after the mesh is made) and prints the
time until the child exits.

    python benches/ctrl_c_theta_phi.py 1 2 3 4
"""
import os, signal, subprocess, sys, time
child = r'''
import sys, time, numpy as np, spherify as sp
mesh = sp.datasets.make("bumpy_blob", 1000000)
print("ready", mesh.n_vertices, flush=True)
t = time.time()
try:
    sp.embed(mesh, method="theta_phi")
    print("done", time.time() - t, flush=True)
except KeyboardInterrupt:
    print("interrupted", time.time() - t, flush=True)
'''
for delay in [float(x) for x in sys.argv[1:]]:
    p = subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE, text=True)
    line = p.stdout.readline().strip()
    time.sleep(delay)
    t0 = time.time()
    p.send_signal(signal.SIGINT)
    out = p.stdout.read().strip()
    p.wait()
    print(f"{line}; SIGINT at {delay} s -> exit after {time.time() - t0:.2f} s ({out})", flush=True)
