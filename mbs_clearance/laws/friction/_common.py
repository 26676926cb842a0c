"""The parameters shared by the friction laws' declarations (the description's fields)."""

from ..base import Parameter

MU = Parameter("friction_coefficient", "mu", "-", 0.0, 0.0,
               source="0: frictionless; give the pair's value (steel on steel, dry: about "
                      "0.1-0.2; lubricated about 0.01)")
V0 = Parameter("friction_v0", "v0", "m/s", 1e-4, 0.0, low_open=True,
               source="assumed: a typical lower threshold of Ambrosio's law (the law: "
                      "Ambrosio 2002); the paper's joint is frictionless and gives none")
V1 = Parameter("friction_v1", "v1", "m/s", 1e-2, 0.0, low_open=True,
               source="assumed: a typical upper threshold of Ambrosio's law (the law: "
                      "Ambrosio 2002); the paper's joint is frictionless and gives none")
