"""AIS (issue 17): decode !AIVDM/!AIVDO lines, keep a table of AIS targets, associate them with the
camera's tracks, flag the dark ones and check the calibration against class-A ships."""
