"""The finite-element rotor (Friswell et al., "Dynamics of Rotating Machines", 2010).

Modules: ``timoshenko`` (shaft element), ``disc`` (rigid disc), ``assembly`` (``Rotor``),
``supports`` (linear bearings, Lund's convention), ``modal`` (damped modes, Campbell diagram),
``response`` (unbalance response, static deflection).
"""
