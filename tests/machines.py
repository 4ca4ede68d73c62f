"""Model files (SPEC §8) the tests write: small machines with a known closed form or a known answer."""

SPAN_MM, DIAMETER_MM, E = 400.0, 60.0, 2.1e11

_BEARING = """
[[bearings]]
node = {node}
radius_mm = 30.0
length_mm = 30.0
clearance_um = 40.0
viscosity_pa_s = {mu}
groove_angle_deg = 0.0
groove_length_mm = 8.0
groove_width_mm = 15.0
mesh_circumferential = 40
mesh_axial = 20
offset_um = [0.0, {dy}]
"""


def uniform_three_bearing_file(tmp_path, *, viscosity=0.03, offset_um=0.0, support=None, name="three",
                               pedestal=None):
    """A uniform 60 mm shaft, 800 mm long, on three equal L/D = 0.5 bearings at its ends and middle (two equal spans)
    with a 40 kg wheel in the middle, coarse films (40 x 20) to keep tests quick; optionally the middle bearing
    raised by `offset_um` and a ball bearing a quarter along with constant stiffness `support` = (kXX, kYY) N/m and
    1e3 N s/m damping; `pedestal` = (mass kg, stiffness N/m, damping N s/m) under the middle bearing. Returns the
    file's path."""
    elements = ", ".join(f"[{SPAN_MM / 4}, {DIAMETER_MM}]" for _ in range(8))
    text = f"""
[machine]
name = "{name}"
gravity_m_s2 = 9.81
operating_speed_hz = 50.0
[material]
young_modulus_pa = {E}
poisson_ratio = 0.3
density_kg_m3 = 7850.0
[shaft]
damping_beta_s = 1.0e-5
elements_mm = [{elements}]
[[discs]]
node = 5
mass_kg = 40.0
polar_inertia_kg_m2 = 0.2
diametral_inertia_kg_m2 = 0.1
[unbalance]
node = 3
moment_kg_m = 1.0e-4
phase_deg = 0.0
""" + "".join(_BEARING.format(node=n, mu=viscosity, dy=offset_um if n == 5 else 0.0)
             + (f"pedestal_mass_kg = {pedestal[0]:g}\npedestal_stiffness_n_m = {pedestal[1]:g}\n"
                f"pedestal_damping_ns_m = {pedestal[2]:g}\n" if n == 5 and pedestal else "") for n in (1, 5, 9))
    if support is not None:
        text += f"""
[[supports]]
name = "ball bearing"
node = 3
stiffness_n_m = [[{support[0]:g}, 0.0], [0.0, {support[1]:g}]]
damping_ns_m = [[1.0e3, 0.0], [0.0, 1.0e3]]
"""
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def one_x_with_films(machine, truth, nodes, extra_force=None):
    """The model's rotor (`rotor_from_machine`) at the machine's operating speed on the films of an independent
    record's `truth` (its K, C per bearing): the 1X (x, y) at `nodes` under the machine's unbalance plus
    `extra_force(rotor, omega)` (an effect's forcing, or None). The two implementations then share their films and
    differ in their rotor and forcing alone."""
    import numpy as np

    from lubeviz.identify.forward.chain import machine_unbalance
    from lubeviz.rotor.assembly import rotor_from_machine
    from lubeviz.rotor.elements import X, Y, node_dofs
    from lubeviz.rotor.response import dynamic_stiffness, unbalance_force

    rotor = rotor_from_machine(machine)
    w = 2 * np.pi * machine.operating_speed
    D = dynamic_stiffness(rotor, w, rotor.K, rotor.C)
    for k, n in enumerate(rotor.bearing_nodes):
        d = node_dofs(n)[[X, Y]]
        D[np.ix_(d, d)] += truth["K"][k] + 1j * w * truth["C"][k]
    F = unbalance_force(rotor, w, machine_unbalance(machine))
    if extra_force is not None:
        F = F + extra_force(rotor, w)
    x = np.linalg.solve(D, F)
    return np.array([x[node_dofs(n)[[X, Y]]] for n in nodes])
