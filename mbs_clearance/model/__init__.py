"""What a mechanism is: the general description (`linkage.Linkage`), the paper's
named parameter set (`mechanism.SliderCrank`), the named cases (`cases`), design
fields by name and dotted path (`design`) and ISO 286 fits (`fits`)."""
