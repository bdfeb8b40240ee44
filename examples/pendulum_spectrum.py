"""The paper's pendulum: run flexmbd for 0.5 s, find the tip's vibration frequency in its spectrum
and set it beside the linearized system's first in-plane bending frequency."""

import numpy as np

import flexmbd

df = flexmbd.run("pendulum", "flexmbd", t_end=0.5)
y = df["tip_deflection"].to_numpy()
t = df.index.to_numpy()
y = (y - np.polyval(np.polyfit(t, y, 3), t)) * np.hanning(t.size)          # vibration about the swing
f = np.fft.rfftfreq(8 * t.size, t[1] - t[0])
peak = f[np.argmax(np.abs(np.fft.rfft(y, 8 * t.size)) * (f > 5.0))]
modes = flexmbd.system_modes("pendulum")
inplane = modes[modes.label.str.contains("xy")].freq_hz.iloc[0]
print(f"tip spectrum peak {peak:.2f} Hz; system's first in-plane bending {inplane:.2f} Hz")
assert abs(peak / inplane - 1) < 0.05
