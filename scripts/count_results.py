#!/usr/bin/python3
"""Sums JUnit XML results (gtest, rostest) below the given folders; prints the failures and the
closing line 'N passed, N failed'; exits 1 when anything failed or nothing ran."""
import glob
import os
import sys
import xml.etree.ElementTree as ET

passed = failed = 0
for root in sys.argv[1:]:
    for path in sorted(glob.glob(os.path.join(root, '**', '*.xml'), recursive=True)):
        try:
            tree = ET.parse(path)
        except ET.ParseError as e:
            print('unreadable result %s: %s' % (path, e))
            failed += 1
            continue
        cases = list(tree.getroot().iter('testcase'))
        if not cases:  # a suite that ran nothing (a crashed binary) counts as a failure
            print('no test cases in %s' % path)
            failed += 1
        for case in cases:
            bad = case.find('failure') is not None or case.find('error') is not None
            if case.get('status') == 'notrun' or case.find('skipped') is not None:
                continue
            if bad:
                failed += 1
                print('FAILED %s.%s (%s)' % (case.get('classname'), case.get('name'), path))
            else:
                passed += 1
print('%d passed, %d failed' % (passed, failed))
sys.exit(1 if failed or not passed else 0)
