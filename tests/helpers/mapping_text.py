"""Mapping text shared by the import tests."""

#: the ``[[calibration_amplitude]]`` every mapping needs, as constants, for tests whose
#: subject is another table (files: every results file under ``results/``)
CALIBRATION_STUB = ('[[calibration_amplitude]]\nfiles = "results/**/*.h5"\n'
                    '[calibration_amplitude.columns]\nA = 0.5\npower = 1.0\n\n')
