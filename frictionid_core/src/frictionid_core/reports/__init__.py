"""HTML reports: of one result on any data (:mod:`.result_report`) and of the EMPS benchmark
(:mod:`.emps_report`), both drawn with :mod:`.html_page`."""
